//! A.R.T. DTrack2 ASCII output over UDP (`[tracking] source = "dtrack"`; `live.rs` runs the
//! source). One packet is one frame of lines separated by CR/LF; vlf reads:
//!
//! - `6d n [id qu][sx sy sz (eta theta phi)][b0 .. b8] ...`: n standard bodies, quality `qu`
//!   (negative: not tracked), position in millimetres, rotation matrix column by column
//!   (b0 b1 b2 is the first column); body `head_id` is the head, body `left_hand_id` (if
//!   configured) the left hand, and a `[[tracking.target]]`'s body `id` that target;
//! - `6df2 ndef n [id qu nbt nct][sx sy sz][b0 .. b8][bt0 .. ct0 ct1 ..] ...`: n Flysticks
//!   with `nbt` buttons (32 to an integer, bit i button i: 0 the trigger) and `nct` controllers
//!   (joystick x, y in -1..1); Flystick `wand_id` is the wand;
//! - `6df n [id qu bt][sx sy sz (eta theta phi)][b0 .. b8] ...`: the older Flystick format
//!   (8 button bits, the hat switch as joystick bits 0x10 down, 0x20 left, 0x40 up, 0x80 right).
//!
//! `fr`, `ts`, `6dcal`, `3d`, `6dmt` and unknown lines are skipped.

use super::calibration::RoomFromTracker;
use super::live::Measurement;
use glam::{Mat3, Quat, Vec3};

/// Read one DTrack2 packet into measurements of the head (body `head_id`), the left hand (body
/// `left_hand_id`), the targets (their bodies' ids) and the wand (Flystick `wand_id`): its pose,
/// buttons and joystick.
pub fn parse(
    packet: &[u8],
    ids: &RoomFromTracker,
    out: &mut Vec<Measurement>,
) -> std::result::Result<(), String> {
    let text =
        std::str::from_utf8(packet).map_err(|_| "not DTrack ASCII (not UTF-8 text)".to_string())?;
    for line in text
        .split(['\r', '\n'])
        .map(str::trim)
        .filter(|l| !l.is_empty())
    {
        let (kind, rest) = line.split_once(char::is_whitespace).unwrap_or((line, ""));
        let result = match kind {
            "6d" => bodies(rest, ids, out),
            "6df2" => flysticks2(rest, ids.wand_id, out),
            "6df" => flysticks1(rest, ids.wand_id, out),
            _ => Ok(()),
        };
        result.map_err(|e| format!("DTrack line {kind:?}: {e}"))?;
    }
    Ok(())
}

/// A line after its identifier: the numbers before the first block, and the blocks' numbers.
fn split(rest: &str) -> std::result::Result<(Vec<f64>, Vec<Vec<f64>>), String> {
    let number = |t: &str| {
        t.parse::<f64>()
            .map_err(|_| format!("{t:?} is not a number"))
    };
    let (head, blocks_text) = rest
        .split_once('[')
        .map_or((rest, None), |(h, b)| (h, Some(b)));
    let header = head
        .split_whitespace()
        .map(number)
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let mut blocks = Vec::new();
    let mut next = blocks_text;
    while let Some(text) = next {
        let (inside, after) = text.split_once(']').ok_or("a block has no closing ']'")?;
        blocks.push(
            inside
                .split_whitespace()
                .map(number)
                .collect::<std::result::Result<Vec<_>, _>>()?,
        );
        let after = after.trim_start();
        next = match after.strip_prefix('[') {
            Some(text) => Some(text),
            None if after.is_empty() => None,
            None => return Err(format!("unexpected {after:?} between blocks")),
        };
    }
    Ok((header, blocks))
}

/// The number of items a line announces (its `index`th header number).
fn count(header: &[f64], index: usize) -> std::result::Result<usize, String> {
    match header.get(index) {
        Some(&n) if n >= 0.0 && n.fract() == 0.0 && n < 1e6 => Ok(n as usize),
        _ => Err(format!("expected a count of items, found {:?}", header)),
    }
}

/// Position (first three numbers of a block, tracker units) and rotation (9 numbers, column by
/// column) of a body.
fn pose(position: &[f64], matrix: &[f64]) -> std::result::Result<(Vec3, Quat), String> {
    if position.len() < 3 {
        return Err(format!(
            "a position needs 3 numbers, found {}",
            position.len()
        ));
    }
    if matrix.len() != 9 {
        return Err(format!(
            "a rotation matrix needs 9 numbers, found {}",
            matrix.len()
        ));
    }
    let m: [f32; 9] = std::array::from_fn(|i| matrix[i] as f32);
    let rotation = Quat::from_mat3(&Mat3::from_cols_array(&m));
    if !rotation.is_finite() || rotation.length() < 1e-3 {
        return Err("the rotation matrix is not a rotation".into());
    }
    Ok((
        Vec3::new(position[0] as f32, position[1] as f32, position[2] as f32),
        rotation.normalize(),
    ))
}

fn id_quality(block: &[f64], fields: usize) -> std::result::Result<(u32, f64), String> {
    if block.len() != fields || block[0] < 0.0 || block[0].fract() != 0.0 {
        return Err(format!(
            "expected [id quality ...] with {fields} numbers, found {block:?}"
        ));
    }
    Ok((block[0] as u32, block[1]))
}

/// The standard bodies of a `6d` line: the head's, the left hand's (where one is configured)
/// and the targets' poses, each only while tracked (a body out of view keeps its last pose).
fn bodies(
    rest: &str,
    ids: &RoomFromTracker,
    out: &mut Vec<Measurement>,
) -> std::result::Result<(), String> {
    let (header, blocks) = split(rest)?;
    let n = count(&header, 0)?;
    if blocks.len() != 3 * n {
        return Err(format!(
            "{n} bodies need {} blocks, found {}",
            3 * n,
            blocks.len()
        ));
    }
    for body in blocks.chunks(3) {
        let (id, quality) = id_quality(&body[0], 2)?;
        let (position, rotation) = pose(&body[1], &body[2])?;
        if quality < 0.0 {
            continue;
        }
        if id == ids.head_id {
            out.push(Measurement::Head {
                position,
                rotation: Some(rotation),
            });
        } else if ids.left_hand_id == Some(id) {
            out.push(Measurement::LeftHand { position, rotation });
        } else if let Some(index) = ids.target_of(id) {
            out.push(Measurement::Target {
                index,
                position,
                rotation,
            });
        }
    }
    Ok(())
}

fn flysticks2(
    rest: &str,
    wand_id: u32,
    out: &mut Vec<Measurement>,
) -> std::result::Result<(), String> {
    let (header, blocks) = split(rest)?;
    let n = count(&header, 1)?;
    if blocks.len() != 4 * n {
        return Err(format!(
            "{n} Flysticks need {} blocks, found {}",
            4 * n,
            blocks.len()
        ));
    }
    for stick in blocks.chunks(4) {
        let (id, quality) = id_quality(&stick[0], 4)?;
        let (buttons, controllers) = (count(&stick[0], 2)?, count(&stick[0], 3)?);
        let words = buttons.div_ceil(32);
        if stick[3].len() != words + controllers {
            return Err(format!(
                "Flystick {id}: {buttons} buttons and {controllers} controllers need {} numbers, found {}",
                words + controllers,
                stick[3].len()
            ));
        }
        let (position, rotation) = pose(&stick[1], &stick[2])?;
        if id != wand_id {
            continue;
        }
        if quality >= 0.0 {
            out.push(Measurement::Wand { position, rotation });
        }
        let mut mask = 0u64;
        for (w, word) in stick[3][..words.min(2)].iter().enumerate() {
            mask |= ((*word as i64 as u64) & 0xffff_ffff) << (32 * w);
        }
        if buttons < 64 {
            mask &= (1u64 << buttons) - 1;
        }
        out.push(Measurement::Buttons(mask));
        let axis = |i: usize| stick[3].get(words + i).map_or(0.0, |v| *v as f32);
        out.push(Measurement::Joystick([axis(0), axis(1)]));
    }
    Ok(())
}

fn flysticks1(
    rest: &str,
    wand_id: u32,
    out: &mut Vec<Measurement>,
) -> std::result::Result<(), String> {
    let (header, blocks) = split(rest)?;
    let n = count(&header, 0)?;
    if blocks.len() != 3 * n {
        return Err(format!(
            "{n} Flysticks need {} blocks, found {}",
            3 * n,
            blocks.len()
        ));
    }
    for stick in blocks.chunks(3) {
        let (id, quality) = id_quality(&stick[0], 3)?;
        let bits = stick[0][2] as i64 as u64;
        let (position, rotation) = pose(&stick[1], &stick[2])?;
        if id != wand_id {
            continue;
        }
        if quality >= 0.0 {
            out.push(Measurement::Wand { position, rotation });
        }
        out.push(Measurement::Buttons(bits & 0x0f));
        let hat = |minus: u64, plus: u64| {
            if bits & minus != 0 {
                -1.0
            } else if bits & plus != 0 {
                1.0
            } else {
                0.0
            }
        };
        out.push(Measurement::Joystick([hat(0x20, 0x80), hat(0x10, 0x40)]));
    }
    Ok(())
}
