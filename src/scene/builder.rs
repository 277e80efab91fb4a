//! Meshes written from code: squares and boxes as OBJ text, for the stability cases
//! (`vlf stress`) and the tests, which load them through the real importer like any scene.

use glam::DVec3;
use std::fmt::Write as _;

/// An OBJ built from quads, each with a material.
#[derive(Clone, Debug, Default)]
pub struct QuadMesh {
    obj: String,
}

impl QuadMesh {
    /// A rectangle `size` centred at `c`, facing `normal` (counter-clockwise seen from the
    /// front); `spin` rotates it in its plane.
    pub fn quad(
        &mut self,
        material: &str,
        c: DVec3,
        normal: DVec3,
        size: [f64; 2],
        spin: f64,
    ) -> &mut Self {
        let n = normal.normalize();
        let helper = if n.x.abs() < 0.6 { DVec3::X } else { DVec3::Y };
        let t1 = (helper - n * n.dot(helper)).normalize();
        let t2 = n.cross(t1);
        let (s, co) = spin.sin_cos();
        let (t1, t2) = (t1 * co + t2 * s, -t1 * s + t2 * co);
        let (a, b) = (t1 * size[0] * 0.5, t2 * size[1] * 0.5);
        let _ = writeln!(self.obj, "usemtl {material}");
        for p in [c - a - b, c + a - b, c + a + b, c - a + b] {
            let _ = writeln!(self.obj, "v {} {} {}", p.x, p.y, p.z);
        }
        self.obj.push_str("f -4 -3 -2 -1\n");
        self
    }

    /// A closed axis-aligned box of half-size `h` at `c`; faces inward when `inward`.
    pub fn cube(&mut self, material: &str, c: DVec3, h: f64, inward: bool) -> &mut Self {
        for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
            for sign in [1.0, -1.0] {
                let outward = axis * sign;
                let normal = if inward { -outward } else { outward };
                self.quad(material, c + outward * h, normal, [2.0 * h, 2.0 * h], 0.0);
            }
        }
        self
    }

    /// The OBJ file's text, referring to the material library `mtllib`.
    pub fn text(&self, mtllib: &str) -> String {
        format!("mtllib {mtllib}\n{}", self.obj)
    }
}
