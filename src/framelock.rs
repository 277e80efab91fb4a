//! The frame lock between the drawing loops and a cluster (`crate::cluster`): the state rank 0
//! broadcasts every frame (`FrameState`: frame number, head, wand, left hand, the declared
//! targets, navigation, exposure,
//! the moving objects' time, and a study's state: condition, objects shown, their shadows and
//! reflections, the latency test's flash, the script's stop) and what the headless and windowed loops call (`FrameLock`: share the state at the start of a
//! frame, then a swap barrier just before present). It sits below both: the display's loops
//! (`crate::display`) call the trait, the cluster's MPI side implements it, and neither names the
//! other's module for it.

use crate::error::Result;
use crate::tracking::{HeldPoses, Pose, Targets, WandPose, MAX_TARGETS};
use glam::{Quat, Vec3};

/// What every rank draws a frame from, as rank 0 broadcasts it (368 bytes: fixed, whatever
/// the display declares, so every rank sends and receives one size; the targets take
/// `MAX_TARGETS` slots).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct FrameState {
    pub frame: u64,
    pub head: [f32; 3],
    pub head_rotation: [f32; 4],
    pub room_position: [f32; 3],
    pub room_yaw_deg: f32,
    pub wand_position: [f32; 3],
    pub wand_rotation: [f32; 4],
    pub exposure: f32,
    /// bit 0: the run ends (nothing to draw); bit 1: a wand is tracked; bit 2: a left hand is;
    /// then the study's switches (`StudyState`)
    pub flags: u32,
    pub left_hand_position: [f32; 3],
    pub left_hand_rotation: [f32; 4],
    /// the study's condition in effect: its index in the display's `[[condition]]` list, or
    /// `NO_CONDITION`
    pub condition: u32,
    /// the moving objects hidden, bit k for the display's `[[object]]` k (the first 64)
    pub objects_hidden: u64,
    /// the moving objects' animation time (keyframes, scripted paths), seconds: rank 0's clock
    pub object_time_s: f64,
    /// the declared targets (`[[tracking.target]]`, by index) where tracked: bit k for target k
    pub targets_tracked: u32,
    pub target_positions: [[f32; 3]; MAX_TARGETS],
    pub target_rotations: [[f32; 4]; MAX_TARGETS],
    /// (explicit padding to the struct's 8-byte alignment: `Pod` has none hidden)
    pub _pad: u32,
}

const QUIT: u32 = 1;
const HAS_WAND: u32 = 2;
const HAS_LEFT_HAND: u32 = 4;
const NO_SHADOWS: u32 = 8;
const NO_REFLECTIONS: u32 = 16;
const FLASH_WHITE: u32 = 32;
const FLASH_BLACK: u32 = 64;
const STOP: u32 = 128;

/// `FrameState::condition` where the display has no conditions.
pub const NO_CONDITION: u32 = u32::MAX;

/// What a study sets on every rank's frame (rank 0's session decides it, `crate::study`): the
/// condition, the moving objects hidden, their shadows and reflections, the latency test's
/// walls, and whether the script stopped the run with this frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StudyState {
    /// index into the display's conditions
    pub condition: Option<u32>,
    /// bit k: the display's moving object k is hidden
    pub objects_hidden: u64,
    pub shadows: bool,
    pub reflections: bool,
    /// Some(true): walls full white; Some(false): black; None: the scene
    pub flash: Option<bool>,
    /// the script's `stop`: this frame is the last
    pub stop: bool,
}

impl Default for StudyState {
    fn default() -> StudyState {
        StudyState {
            condition: None,
            objects_hidden: 0,
            shadows: true,
            reflections: true,
            flash: None,
            stop: false,
        }
    }
}

impl FrameState {
    pub fn new(frame: u64, pose: &Pose, held: HeldPoses, exposure: f32) -> FrameState {
        let (wand, left_hand) = (held.wand.as_ref(), held.left_hand.as_ref());
        let flag = |on: bool, bit: u32| if on { bit } else { 0 };
        FrameState {
            frame,
            head: pose.head.into(),
            head_rotation: pose.head_rotation.to_array(),
            room_position: pose.room_position.into(),
            room_yaw_deg: pose.room_yaw_deg,
            wand_position: wand.map_or([0.0; 3], |w| w.position.into()),
            wand_rotation: wand.map_or([0.0, 0.0, 0.0, 1.0], |w| w.rotation.to_array()),
            exposure,
            flags: flag(wand.is_some(), HAS_WAND) | flag(left_hand.is_some(), HAS_LEFT_HAND),
            left_hand_position: left_hand.map_or([0.0; 3], |h| h.position.into()),
            left_hand_rotation: left_hand.map_or([0.0, 0.0, 0.0, 1.0], |h| h.rotation.to_array()),
            condition: NO_CONDITION,
            objects_hidden: 0,
            object_time_s: 0.0,
            targets_tracked: (held.targets.iter().enumerate())
                .filter(|(_, t)| t.is_some())
                .fold(0, |bits, (k, _)| bits | 1 << k),
            target_positions: held
                .targets
                .map(|t| t.map_or([0.0; 3], |t| t.position.into())),
            target_rotations: held
                .targets
                .map(|t| t.map_or([0.0, 0.0, 0.0, 1.0], |t| t.rotation.to_array())),
            _pad: 0,
        }
    }
    /// This state with the moving objects' time and a study's state.
    pub fn with_study(mut self, object_time_s: f64, study: StudyState) -> FrameState {
        let flag = |on: bool, bit: u32| if on { bit } else { 0 };
        self.object_time_s = object_time_s;
        self.condition = study.condition.unwrap_or(NO_CONDITION);
        self.objects_hidden = study.objects_hidden;
        self.flags = (self.flags & (QUIT | HAS_WAND | HAS_LEFT_HAND))
            | flag(!study.shadows, NO_SHADOWS)
            | flag(!study.reflections, NO_REFLECTIONS)
            | flag(study.flash == Some(true), FLASH_WHITE)
            | flag(study.flash == Some(false), FLASH_BLACK)
            | flag(study.stop, STOP);
        self
    }
    /// The study's state rank 0 set.
    pub fn study(&self) -> StudyState {
        let on = |bit: u32| self.flags & bit != 0;
        StudyState {
            condition: (self.condition != NO_CONDITION).then_some(self.condition),
            objects_hidden: self.objects_hidden,
            shadows: !on(NO_SHADOWS),
            reflections: !on(NO_REFLECTIONS),
            flash: match (on(FLASH_WHITE), on(FLASH_BLACK)) {
                (true, _) => Some(true),
                (false, true) => Some(false),
                _ => None,
            },
            stop: on(STOP),
        }
    }
    pub fn quit(frame: u64) -> FrameState {
        FrameState {
            flags: QUIT,
            ..FrameState::new(
                frame,
                &Pose::new(Vec3::ZERO, Vec3::ZERO, 0.0),
                HeldPoses::default(),
                1.0,
            )
        }
    }
    pub fn is_quit(&self) -> bool {
        self.flags & QUIT != 0
    }
    pub fn pose(&self) -> Pose {
        Pose {
            head: Vec3::from(self.head),
            head_rotation: Quat::from_array(self.head_rotation),
            room_position: Vec3::from(self.room_position),
            room_yaw_deg: self.room_yaw_deg,
        }
    }
    pub fn wand(&self) -> Option<WandPose> {
        (self.flags & HAS_WAND != 0).then(|| WandPose {
            position: Vec3::from(self.wand_position),
            rotation: Quat::from_array(self.wand_rotation),
        })
    }
    pub fn left_hand(&self) -> Option<WandPose> {
        (self.flags & HAS_LEFT_HAND != 0).then(|| WandPose {
            position: Vec3::from(self.left_hand_position),
            rotation: Quat::from_array(self.left_hand_rotation),
        })
    }
    /// The declared targets, each where tracked.
    pub fn targets(&self) -> Targets {
        std::array::from_fn(|k| {
            (self.targets_tracked & 1 << k != 0).then(|| WandPose {
                position: Vec3::from(self.target_positions[k]),
                rotation: Quat::from_array(self.target_rotations[k]),
            })
        })
    }
    /// The wand, the left hand and the targets.
    pub fn held(&self) -> HeldPoses {
        HeldPoses {
            wand: self.wand(),
            left_hand: self.left_hand(),
            targets: self.targets(),
        }
    }
    /// CRC-32 of everything but the frame number: equal poses, wands, left hands, targets,
    /// exposure and study state.
    pub fn pose_digest(&self) -> u32 {
        crc32fast::hash(&bytemuck::bytes_of(self)[8..])
    }
}

/// The frame lock the drawing loops call: `share` at the start of every frame (rank 0 gives
/// its state, every rank gets rank 0's), `swap` when the frame is drawn, just before present.
pub trait FrameLock {
    fn is_leader(&self) -> bool;
    fn share(&mut self, state: FrameState) -> Result<FrameState>;
    fn swap(&mut self) -> Result<()>;
    /// The swap barrier of a frame that is not a displayed frame (a headless run's last frame,
    /// read back for the images): locked like any other, but not counted in the frame times.
    fn swap_untimed(&mut self) -> Result<()> {
        self.swap()
    }
}
