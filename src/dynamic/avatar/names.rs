//! The joints the rig drives, and the names a skin's joints may have for each: vlf's own
//! (`head`, `upper_arm_l`, ...), Mixamo's (`mixamorig:Head`, `mixamorig:LeftArm`, ...),
//! Unreal's (`upperarm_l`, `lowerarm_l`), VRM's (`leftUpperArm`, `leftLowerArm`), Blender
//! Rigify's deform bones (`DEF-upper_arm.L`) and 3ds Max Biped's (`Bip01 L UpperArm`).
//!
//! Names are compared after [`normalise`]: lower case, anything up to the last `:` dropped,
//! only letters and digits kept, and a leading `mixamorig`, `def`, `bip01`/`bip001` or
//! `armature` prefix removed.

/// A joint the rig knows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    Hips,
    Neck,
    Head,
    UpperArmLeft,
    ForearmLeft,
    HandLeft,
    UpperArmRight,
    ForearmRight,
    HandRight,
}

impl Role {
    /// The joints `Avatar::load` refuses a skin without.
    pub const REQUIRED: [Role; 7] = [
        Role::Head,
        Role::UpperArmLeft,
        Role::ForearmLeft,
        Role::HandLeft,
        Role::UpperArmRight,
        Role::ForearmRight,
        Role::HandRight,
    ];

    pub const ALL: [Role; 9] = [
        Role::Hips,
        Role::Neck,
        Role::Head,
        Role::UpperArmLeft,
        Role::ForearmLeft,
        Role::HandLeft,
        Role::UpperArmRight,
        Role::ForearmRight,
        Role::HandRight,
    ];

    /// The normalised names accepted for this joint, vlf's own first.
    pub fn aliases(self) -> &'static [&'static str] {
        match self {
            Role::Hips => &["hips", "hip", "pelvis"],
            Role::Neck => &["neck", "neck1", "neck01"],
            Role::Head => &["head"],
            Role::UpperArmLeft => &[
                "upperarml",
                "leftarm",
                "leftupperarm",
                "upperarmleft",
                "lupperarm",
            ],
            Role::ForearmLeft => &[
                "forearml",
                "leftforearm",
                "lowerarml",
                "leftlowerarm",
                "forearmleft",
                "lforearm",
            ],
            Role::HandLeft => &["handl", "lefthand", "handleft", "lhand"],
            Role::UpperArmRight => &[
                "upperarmr",
                "rightarm",
                "rightupperarm",
                "upperarmright",
                "rupperarm",
            ],
            Role::ForearmRight => &[
                "forearmr",
                "rightforearm",
                "lowerarmr",
                "rightlowerarm",
                "forearmright",
                "rforearm",
            ],
            Role::HandRight => &["handr", "righthand", "handright", "rhand"],
        }
    }

    /// vlf's own name for the joint (what an error message suggests).
    pub fn name(self) -> &'static str {
        match self {
            Role::Hips => "hips",
            Role::Neck => "neck",
            Role::Head => "head",
            Role::UpperArmLeft => "upper_arm_l",
            Role::ForearmLeft => "forearm_l",
            Role::HandLeft => "hand_l",
            Role::UpperArmRight => "upper_arm_r",
            Role::ForearmRight => "forearm_r",
            Role::HandRight => "hand_r",
        }
    }
}

/// A joint name reduced for comparison (see the module's documentation).
pub fn normalise(name: &str) -> String {
    let lower = name.to_ascii_lowercase();
    let tail = lower.rsplit(':').next().unwrap_or(&lower);
    let mut s: String = tail.chars().filter(|c| c.is_ascii_alphanumeric()).collect();
    for prefix in ["mixamorig", "bip001", "bip01", "armature", "def"] {
        if let Some(rest) = s.strip_prefix(prefix) {
            let rest = rest.trim_start_matches(|c: char| c.is_ascii_digit());
            if !rest.is_empty() {
                s = rest.to_string();
            }
            break;
        }
    }
    s
}

/// The first joint whose name is one of the role's aliases (by the alias's rank, so that
/// vlf's own name wins over an alternative).
pub fn find(names: &[String], role: Role) -> Option<usize> {
    let normalised: Vec<String> = names.iter().map(|n| normalise(n)).collect();
    role.aliases()
        .iter()
        .find_map(|alias| normalised.iter().position(|n| n == alias))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn common_rigs_names_are_recognised() {
        let cases = [
            ("mixamorig:LeftArm", Role::UpperArmLeft),
            ("mixamorig1:RightForeArm", Role::ForearmRight),
            ("mixamorig_LeftHand", Role::HandLeft),
            ("DEF-upper_arm.R", Role::UpperArmRight),
            ("lowerarm_l", Role::ForearmLeft),
            ("Bip01 R Hand", Role::HandRight),
            ("leftUpperArm", Role::UpperArmLeft),
            ("Hips", Role::Hips),
            ("mixamorig:Head", Role::Head),
        ];
        for (name, role) in cases {
            assert_eq!(
                find(&[String::from("x"), name.to_string()], role),
                Some(1),
                "{name}"
            );
        }
        assert_eq!(find(&["LeftForeArm".to_string()], Role::UpperArmLeft), None);
    }
}
