//! Tracked targets besides the head and the two hands (`[[tracking.target]]` in a display
//! config): a named rigid body, a chair or a tracked prop, that moving objects follow
//! (`follow = "target"` with `target = "<name>"`, `crate::dynamic`). A live source says which of
//! its bodies each one is: DTrack's `6d` body or VRPN's sensor `id`, OSC the address
//! `/vlf/target/<name>`; a static source holds one still at `position` (the wand's keys), a
//! scripted path moves it by its keyframes' `[[keyframe.target]]` tables. A target is numbered
//! by its place in the list; there are at most `MAX_TARGETS`, so that the cluster's frame state
//! and the session log's rows keep a fixed size.

use super::pose::{WandPose, MAX_TARGETS};
use serde::{Deserialize, Serialize};

/// One declared target.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TargetConfig {
    /// how objects (`target = "<name>"`), OSC (`/vlf/target/<name>`) and the session log's
    /// columns (`target:<name>`) name it: letters, digits, '_' and '-'
    pub name: String,
    /// the DTrack `6d` body or the VRPN sensor that is this target (live DTrack and VRPN only)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<u32>,
    /// a static source's target held still: room metres, and its orientation as the wand's
    /// (`yaw_deg`/`pitch_deg` or `orientation = [x, y, z, w]`); never seen without a position
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position: Option<[f32; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub yaw_deg: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pitch_deg: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub orientation: Option<[f32; 4]>,
}

/// Which kind of source declares the targets: it decides which keys a target takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TargetSource {
    Static,
    Scripted,
    Osc,
    Dtrack,
    Vrpn,
}

/// Where a target's key is, for errors: `tracking.target[i] ("name").`
pub fn at(index: usize, name: &str) -> String {
    format!("tracking.target[{index}] ({name:?}).")
}

/// Whether `name` can name a target: it goes into an OSC address and the session log's column
/// names, so letters, digits, '_' and '-' only.
pub fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

impl TargetConfig {
    /// A static source's target where `position` puts it (None: not given, never seen).
    pub fn static_pose(&self, index: usize) -> std::result::Result<Option<WandPose>, String> {
        super::wand::held_pose(
            "",
            self.position,
            [self.yaw_deg, self.pitch_deg],
            self.orientation,
            &at(index, &self.name),
        )
    }

    /// The keys this source takes: an id for DTrack and VRPN (and only there), a position for a
    /// static source (and only there).
    fn check_keys(&self, index: usize, source: TargetSource) -> std::result::Result<(), String> {
        let at = at(index, &self.name);
        let by_id = matches!(source, TargetSource::Dtrack | TargetSource::Vrpn);
        match (self.id, by_id) {
            (None, true) => {
                return Err(format!(
                    "{at}id: give the {} that is this target",
                    match source {
                        TargetSource::Dtrack => "DTrack 6d body id",
                        _ => "VRPN sensor",
                    }
                ))
            }
            (Some(_), false) => {
                return Err(format!(
                    "{at}id: only DTrack and VRPN name a target by id ({}): drop it",
                    match source {
                        TargetSource::Osc => format!("OSC sends it as /vlf/target/{}", self.name),
                        TargetSource::Scripted =>
                            "a scripted path moves it by its keyframes' [[keyframe.target]]".into(),
                        _ => "a static target is held at its position".into(),
                    }
                ))
            }
            _ => {}
        }
        let held = self.position.is_some()
            || self.yaw_deg.is_some()
            || self.pitch_deg.is_some()
            || self.orientation.is_some();
        if held && source != TargetSource::Static {
            return Err(format!(
                "{at}position: only a static source holds a target still (this one is {}): drop position and its orientation",
                match source {
                    TargetSource::Scripted => "scripted: its keyframes' [[keyframe.target]] move it",
                    _ => "live: the tracker moves it",
                }
            ));
        }
        self.static_pose(index).map(|_| ())
    }
}

/// The declared targets' checks for a `source`: at most `MAX_TARGETS`, names valid and
/// distinct, ids distinct, each target's keys the ones its source takes. Errors name the key.
/// (An id that is the head's, the wand's or the left hand's is the calibration's check:
/// `calibration::RoomFromTracker::with_targets`.)
pub fn check_targets(
    targets: &[TargetConfig],
    source: TargetSource,
) -> std::result::Result<(), String> {
    if targets.len() > MAX_TARGETS {
        return Err(format!(
            "tracking.target: {} targets declared, at most {MAX_TARGETS} are tracked: drop {}",
            targets.len(),
            targets.len() - MAX_TARGETS
        ));
    }
    for (i, t) in targets.iter().enumerate() {
        if !valid_name(&t.name) {
            return Err(format!(
                "{}name: use letters, digits, '_' and '-' (the name goes into OSC's /vlf/target/<name> and the session log's columns)",
                at(i, &t.name)
            ));
        }
        if let Some(j) = targets[..i].iter().position(|o| o.name == t.name) {
            return Err(format!(
                "{}name: tracking.target[{j}] has this name already: give each target its own",
                at(i, &t.name)
            ));
        }
        if let Some(j) = (targets[..i].iter()).position(|o| t.id.is_some() && o.id == t.id) {
            return Err(format!(
                "{}id: {} is tracking.target[{j}]'s ({:?}) already: one body is one target",
                at(i, &t.name),
                t.id.unwrap_or_default(),
                targets[j].name
            ));
        }
        t.check_keys(i, source)?;
    }
    Ok(())
}

/// The targets' names, in order (a target's index is its place here).
pub fn names(targets: &[TargetConfig]) -> Vec<String> {
    targets.iter().map(|t| t.name.clone()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn targets(text: &str) -> Vec<TargetConfig> {
        #[derive(Deserialize)]
        struct List {
            target: Vec<TargetConfig>,
        }
        toml::from_str::<List>(text).unwrap().target
    }

    #[test]
    fn each_source_takes_its_own_keys_and_errors_name_them() {
        let by_id = targets("[[target]]\nname = \"chair\"\nid = 5");
        assert_eq!(check_targets(&by_id, TargetSource::Dtrack), Ok(()));
        assert_eq!(check_targets(&by_id, TargetSource::Vrpn), Ok(()));
        let e = check_targets(&by_id, TargetSource::Osc).unwrap_err();
        assert!(
            e.contains("tracking.target[0] (\"chair\").id") && e.contains("/vlf/target/chair"),
            "{e}"
        );
        let named = targets("[[target]]\nname = \"chair\"");
        assert_eq!(check_targets(&named, TargetSource::Osc), Ok(()));
        assert_eq!(check_targets(&named, TargetSource::Scripted), Ok(()));
        let e = check_targets(&named, TargetSource::Dtrack).unwrap_err();
        assert!(e.contains("(\"chair\").id") && e.contains("6d body"), "{e}");
        let held = targets("[[target]]\nname = \"chair\"\nposition = [1, 0, -1]\nyaw_deg = 90");
        assert_eq!(check_targets(&held, TargetSource::Static), Ok(()));
        let pose = held[0].static_pose(0).unwrap().unwrap();
        assert!((pose.rotation * glam::Vec3::NEG_Z - glam::Vec3::NEG_X).length() < 1e-6);
        let e = check_targets(&held, TargetSource::Dtrack).unwrap_err();
        assert!(e.contains(".id"), "{e}");
        let e = check_targets(&held, TargetSource::Osc).unwrap_err();
        assert!(
            e.contains("(\"chair\").position") && e.contains("live"),
            "{e}"
        );
        let bad = targets("[[target]]\nname = \"chair\"\nposition = [1, 0, -1]\nyaw_deg = 90\norientation = [0, 0, 0, 1]");
        let e = check_targets(&bad, TargetSource::Static).unwrap_err();
        assert!(e.contains("(\"chair\").orientation"), "{e}");
    }

    #[test]
    fn names_ids_and_the_count_are_checked() {
        let two =
            targets("[[target]]\nname = \"chair\"\nid = 5\n[[target]]\nname = \"chair\"\nid = 6");
        let e = check_targets(&two, TargetSource::Dtrack).unwrap_err();
        assert!(
            e.contains("tracking.target[1] (\"chair\").name") && e.contains("target[0]"),
            "{e}"
        );
        let same_id = targets("[[target]]\nname = \"a\"\nid = 5\n[[target]]\nname = \"b\"\nid = 5");
        let e = check_targets(&same_id, TargetSource::Vrpn).unwrap_err();
        assert!(
            e.contains("tracking.target[1] (\"b\").id") && e.contains("\"a\""),
            "{e}"
        );
        let odd = targets("[[target]]\nname = \"a chair\"");
        let e = check_targets(&odd, TargetSource::Osc).unwrap_err();
        assert!(e.contains(".name") && e.contains("letters"), "{e}");
        let many: String = (0..=MAX_TARGETS)
            .map(|k| format!("[[target]]\nname = \"t{k}\"\nid = {k}\n"))
            .collect();
        let e = check_targets(&targets(&many), TargetSource::Dtrack).unwrap_err();
        assert!(
            e.contains("tracking.target:") && e.contains("at most 8"),
            "{e}"
        );
    }
}
