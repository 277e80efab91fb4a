//! Thumbstick navigation in the headset: an action set bound to the controllers the runtime
//! knows (Touch, Index, Windows Mixed Reality, Vive), read every frame into the navigator; and
//! the controllers' grip poses (those and the Khronos simple controller), located every frame
//! for the body's hands (`body.rs`).

use super::xr_error;
use crate::error::Result;
use crate::tracking::navigator::Navigator;
use crate::tracking::pose::WandPose;
use glam::{Quat, Vec3};
use openxr as xr;

/// Thumbstick navigation: left stick walks and strafes, right stick turns (x) and rises or
/// sinks (y, in fly mode); a button resets to the start.
pub(super) struct Controls {
    pub(super) set: xr::ActionSet,
    walk: xr::Action<xr::Vector2f>,
    turn: xr::Action<xr::Vector2f>,
    reset: xr::Action<bool>,
    fly: xr::Action<bool>,
    /// the left and right controllers' grip poses
    grips: [xr::Action<xr::Posef>; 2],
    pub(super) profiles: Vec<String>,
    /// the buttons last frame: a press acts once
    reset_was_down: bool,
    fly_was_down: bool,
}

pub(super) fn controls(instance: &xr::Instance) -> Result<Controls> {
    let err = xr_error("action set");
    let set = instance
        .create_action_set("navigation", "Navigation", 0)
        .map_err(&err)?;
    let walk = set
        .create_action::<xr::Vector2f>("walk", "Walk (left thumbstick)", &[])
        .map_err(&err)?;
    let turn = set
        .create_action::<xr::Vector2f>("turn", "Turn and rise (right thumbstick)", &[])
        .map_err(&err)?;
    let reset = set
        .create_action::<bool>("reset", "Back to the start", &[])
        .map_err(&err)?;
    let fly = set
        .create_action::<bool>("fly", "Toggle flying", &[])
        .map_err(&err)?;
    let grips = [("left", "Left hand"), ("right", "Right hand")]
        .map(|(side, label)| set.create_action::<xr::Posef>(&format!("{side}_grip"), label, &[]));
    let [left_grip, right_grip] = grips;
    let grips = [left_grip.map_err(&err)?, right_grip.map_err(&err)?];
    let path = |p: &str| instance.string_to_path(p).map_err(xr_error("path"));
    // (profile, walk, turn, reset, fly): thumbsticks where the controller has them, the
    // trackpad on Vive wands
    let suggestions = [
        (
            "/interaction_profiles/oculus/touch_controller",
            "thumbstick",
            "thumbstick",
            "/user/hand/left/input/x/click",
            "/user/hand/right/input/a/click",
        ),
        (
            "/interaction_profiles/valve/index_controller",
            "thumbstick",
            "thumbstick",
            "/user/hand/left/input/a/click",
            "/user/hand/right/input/a/click",
        ),
        (
            "/interaction_profiles/microsoft/motion_controller",
            "thumbstick",
            "thumbstick",
            "/user/hand/left/input/menu/click",
            "/user/hand/right/input/menu/click",
        ),
        (
            "/interaction_profiles/htc/vive_controller",
            "trackpad",
            "trackpad",
            "/user/hand/left/input/menu/click",
            "/user/hand/right/input/menu/click",
        ),
    ];
    let mut profiles = Vec::new();
    let navigation = suggestions
        .map(|(profile, walk, turn, reset, fly)| (profile, Some((walk, turn, reset, fly))));
    // the simple controller has no stick: its grips only
    let simple = ("/interaction_profiles/khr/simple_controller", None);
    for (profile, sticks) in navigation.into_iter().chain([simple]) {
        // a profile's suggestions replace its earlier ones: the grips go with the sticks
        let mut bindings = vec![
            xr::Binding::new(&grips[0], path("/user/hand/left/input/grip/pose")?),
            xr::Binding::new(&grips[1], path("/user/hand/right/input/grip/pose")?),
        ];
        if let Some((walk_input, turn_input, reset_input, fly_input)) = sticks {
            bindings.extend([
                xr::Binding::new(&walk, path(&format!("/user/hand/left/input/{walk_input}"))?),
                xr::Binding::new(
                    &turn,
                    path(&format!("/user/hand/right/input/{turn_input}"))?,
                ),
                xr::Binding::new(&reset, path(reset_input)?),
                xr::Binding::new(&fly, path(fly_input)?),
            ]);
        }
        // a runtime that does not know a profile refuses it; the others still work
        match instance.suggest_interaction_profile_bindings(path(profile)?, &bindings) {
            Ok(()) => profiles.push(
                profile
                    .trim_start_matches("/interaction_profiles/")
                    .to_string(),
            ),
            Err(e) => log::info!("OpenXR runtime refused bindings for {profile}: {e}"),
        }
    }
    if profiles.is_empty() {
        log::warn!(
            "the OpenXR runtime accepted no controller bindings: navigation by thumbstick is off"
        );
    }
    Ok(Controls {
        set,
        walk,
        turn,
        reset,
        fly,
        grips,
        profiles,
        reset_was_down: false,
        fly_was_down: false,
    })
}

/// The controllers' grip spaces, for locating the hands in the reference space each frame.
pub(super) struct Grips {
    spaces: [xr::Space; 2],
}

impl Grips {
    /// The left and right grips in `base` at `time`, each None where the runtime does not know
    /// both its position and its orientation (an untracked hand hangs: `dynamic::avatar`); as
    /// the runtime gave them (the session log keeps them so, `body::hand_in_stage` places them).
    pub(super) fn locate(&self, base: &xr::Space, time: xr::Time) -> Result<[Option<WandPose>; 2]> {
        let mut hands = [None; 2];
        for (hand, space) in hands.iter_mut().zip(&self.spaces) {
            let location = space
                .locate(base, time)
                .map_err(xr_error("xrLocateSpace"))?;
            let valid =
                xr::SpaceLocationFlags::POSITION_VALID | xr::SpaceLocationFlags::ORIENTATION_VALID;
            if location.location_flags.contains(valid) {
                let (o, p) = (location.pose.orientation, location.pose.position);
                let rotation = Quat::from_xyzw(o.x, o.y, o.z, o.w);
                if rotation.is_finite() && rotation.length() > 1e-3 {
                    *hand = Some(WandPose {
                        position: Vec3::new(p.x, p.y, p.z),
                        rotation,
                    });
                }
            }
        }
        Ok(hands)
    }
}

impl Controls {
    /// The grips' spaces in `session` (after the action set is attached).
    pub(super) fn grip_spaces(&self, session: &xr::Session<xr::Vulkan>) -> Result<Grips> {
        let space = |action: &xr::Action<xr::Posef>| {
            action
                .create_space(session.clone(), xr::Path::NULL, xr::Posef::IDENTITY)
                .map_err(xr_error("xrCreateActionSpace"))
        };
        Ok(Grips {
            spaces: [space(&self.grips[0])?, space(&self.grips[1])?],
        })
    }

    /// This frame's sticks as the navigator's axes [strafe right, back, turn right, sink]; a
    /// press of reset or fly acts on `navigator` once.
    pub(super) fn read(
        &mut self,
        session: &xr::Session<xr::Vulkan>,
        navigator: &mut Navigator,
    ) -> Result<[f32; 4]> {
        session
            .sync_actions(&[xr::ActiveActionSet::new(&self.set)])
            .map_err(xr_error("xrSyncActions"))?;
        let stick = |a: &xr::Action<xr::Vector2f>| {
            a.state(session, xr::Path::NULL).map(|s| {
                if s.is_active {
                    s.current_state
                } else {
                    xr::Vector2f::default()
                }
            })
        };
        let walk = stick(&self.walk).map_err(xr_error("thumbstick"))?;
        let turn = stick(&self.turn).map_err(xr_error("thumbstick"))?;
        let button = |a: &xr::Action<bool>| {
            a.state(session, xr::Path::NULL)
                .map(|s| s.is_active && s.current_state)
        };
        let reset_down = button(&self.reset).map_err(xr_error("button"))?;
        let fly_down = button(&self.fly).map_err(xr_error("button"))?;
        if reset_down && !self.reset_was_down {
            navigator.reset();
        }
        if fly_down && !self.fly_was_down {
            navigator.fly = !navigator.fly;
        }
        (self.reset_was_down, self.fly_was_down) = (reset_down, fly_down);
        let dead = |v: f32| if v.abs() < 0.15 { 0.0 } else { v };
        Ok([dead(walk.x), -dead(walk.y), dead(turn.x), -dead(turn.y)])
    }
}
