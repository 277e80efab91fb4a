//! The display TOML's `[[object]]` tables: a moving thing drawn into the light field, what mesh it
//! is, what moves it (the tracked head, wand, left hand or a declared tracked target, keyframes in
//! the world, or the avatar's rig) and whether it is shown. Unknown keys are refused; `check` names the table and key of a bad value.

use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// One moving object.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ObjectConfig {
    /// how a study's script names it (`show`/`hide` over the control connection)
    pub name: String,
    /// a glTF/.glb or OBJ mesh in metres, relative to the display config; for `kind = "avatar"`
    /// a glTF with one skin (`dynamic::avatar`)
    pub mesh: PathBuf,
    #[serde(default)]
    pub kind: ObjectKind,
    /// what moves it; an avatar always follows the head (the wand as its right hand, the
    /// tracked left hand as its left)
    #[serde(default)]
    pub follow: Follow,
    /// `follow = "target"`: which `[[tracking.target]]` (its name)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<String>,
    /// where it sits relative to what it follows (metres; for `world`, in the world)
    #[serde(default)]
    pub position: [f32; 3],
    #[serde(default)]
    pub yaw_deg: f32,
    #[serde(default)]
    pub pitch_deg: f32,
    #[serde(default)]
    pub roll_deg: f32,
    /// uniform scale of the mesh (an avatar's about the tracked head: a body to fit the scene,
    /// its hands still on the tracked ones)
    #[serde(default = "one")]
    pub scale: f32,
    /// `follow = "world"`: placements over time (seconds from the start), interpolated; after
    /// the last one it holds, or starts again with `repeat`
    #[serde(default, rename = "keyframe", skip_serializing_if = "Vec::is_empty")]
    pub keyframes: Vec<ObjectKeyframe>,
    #[serde(default)]
    pub repeat: bool,
    /// shown from the first frame (a study switches it at run time)
    #[serde(default = "yes")]
    pub visible: bool,
}

fn one() -> f32 {
    1.0
}

fn yes() -> bool {
    true
}

#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum ObjectKind {
    /// one rigid mesh
    #[default]
    Rigid,
    /// a skinned glTF body on the participant: under the tracked head, arms to the hands
    Avatar,
}

#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Follow {
    /// placed in the world (with keyframes: animated)
    #[default]
    World,
    /// the tracked head (a helmet, a head-mounted lamp)
    Head,
    /// the tracked wand (a prop in the hand); in the headset, the right controller's grip
    Wand,
    /// the tracked left hand: in the headset, the left controller's grip
    #[serde(rename = "left_hand")]
    LeftHand,
    /// a declared tracked target (`[[tracking.target]]`, the object's `target` names it): hidden
    /// until the target is first seen, then where it was last seen; a CAVE's only (the headset
    /// tracks no targets)
    Target,
}

/// A placement at time `t` seconds: position (metres) and yaw, pitch, roll (degrees, as the
/// head's: yaw about +y, then pitch about x, then roll about z).
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ObjectKeyframe {
    pub t: f32,
    #[serde(default)]
    pub position: [f32; 3],
    #[serde(default)]
    pub yaw_deg: f32,
    #[serde(default)]
    pub pitch_deg: f32,
    #[serde(default)]
    pub roll_deg: f32,
}

impl ObjectConfig {
    /// Whether the values make sense; the error names the table (`object "name"`) and the key.
    pub fn check(&self) -> std::result::Result<(), String> {
        let at = format!("[[object]] \"{}\": ", self.name);
        if self.name.trim().is_empty() {
            return Err("[[object]]: name must not be empty".into());
        }
        if (self.name.chars()).any(|c| c.is_control() || "|,\"".contains(c)) {
            return Err(format!(
                "{at}name: leave out '|', ',', '\"' and control characters (the name goes into the session log's CSV)"
            ));
        }
        let angles = [self.yaw_deg, self.pitch_deg, self.roll_deg];
        if !self.position.iter().chain(&angles).all(|v| v.is_finite()) {
            return Err(format!("{at}position and angles must be finite numbers"));
        }
        if !(self.scale.is_finite() && self.scale > 0.0) {
            return Err(format!("{at}scale = {}: must be above 0", self.scale));
        }
        if !self.keyframes.is_empty() && self.follow != Follow::World {
            return Err(format!(
                "{at}keyframes move an object in the world: give follow = \"world\" or drop them"
            ));
        }
        match (self.follow, &self.target) {
            (Follow::Target, None) => {
                return Err(format!(
                    "{at}follow = \"target\": name the [[tracking.target]] it follows with target = \"<name>\""
                ))
            }
            (Follow::Target, Some(_)) if self.kind == ObjectKind::Avatar => {
                return Err(format!("{at}follow: an avatar follows the tracked head: drop follow and target"))
            }
            (follow, Some(t)) if follow != Follow::Target => {
                return Err(format!(
                    "{at}target = {t:?}: only an object with follow = \"target\" follows a target: give that or drop target"
                ))
            }
            _ => {}
        }
        if self.kind == ObjectKind::Avatar && !self.keyframes.is_empty() {
            return Err(format!(
                "{at}an avatar follows the tracked head: drop its keyframes"
            ));
        }
        for pair in self.keyframes.windows(2) {
            if pair[1].t <= pair[0].t || pair[1].t.is_nan() {
                return Err(format!(
                    "{at}keyframe times must increase ({} then {})",
                    pair[0].t, pair[1].t
                ));
            }
        }
        let frames = self.keyframes.iter();
        for k in frames {
            let values = [k.t, k.yaw_deg, k.pitch_deg, k.roll_deg];
            if !k.position.iter().chain(&values).all(|v| v.is_finite()) {
                return Err(format!(
                    "{at}keyframe at t = {}: values must be finite",
                    k.t
                ));
            }
        }
        Ok(())
    }
}

/// Each object's target index in `targets` (the declared `[[tracking.target]]` names, in
/// order): Some for `follow = "target"` objects, None for the others; an error names the object
/// and the target it names where none is declared so.
pub fn target_indices(
    objects: &[ObjectConfig],
    targets: &[String],
) -> std::result::Result<Vec<Option<usize>>, String> {
    let mut out = Vec::with_capacity(objects.len());
    for o in objects {
        let Some(name) = o.target.as_ref().filter(|_| o.follow == Follow::Target) else {
            out.push(None);
            continue;
        };
        match targets.iter().position(|t| t == name) {
            Some(k) => out.push(Some(k)),
            None => {
                return Err(format!(
                "[[object]] \"{}\": target = {name:?}: no [[tracking.target]] has this name ({})",
                o.name,
                match targets.is_empty() {
                    true => "the tracking declares none".to_string(),
                    false => format!("there are: {}", targets.join(", ")),
                }
            ))
            }
        }
    }
    Ok(out)
}

/// Every object's checks, and no two with one name.
pub fn check_objects(objects: &[ObjectConfig]) -> std::result::Result<(), String> {
    for (i, o) in objects.iter().enumerate() {
        o.check()?;
        if objects[..i].iter().any(|p| p.name == o.name) {
            return Err(format!(
                "[[object]] \"{}\": two objects share this name",
                o.name
            ));
        }
    }
    let avatars = objects
        .iter()
        .filter(|o| o.kind == ObjectKind::Avatar)
        .count();
    if avatars > 1 {
        return Err(format!(
            "[[object]]: {avatars} avatars; one participant is tracked, give one"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_name_that_would_break_the_session_log_is_refused() {
        let object = |name: &str| -> ObjectConfig {
            toml::from_str(&format!("name = {name:?}\nmesh = \"cube.obj\"")).unwrap()
        };
        assert_eq!(object("chair 2").check(), Ok(()));
        for bad in ["a|b", "a,b", "a\"b", "a\nb"] {
            let e = object(bad).check().unwrap_err();
            assert!(e.contains("name") && e.contains("session log"), "{e}");
        }
    }
}
