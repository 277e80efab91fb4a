//! The views of a frame as the reports name them (`ViewLabel`), and the CAVE's: every wall seen
//! by each of its eyes (`WallView`, `wall_views`).

/// A wall seen by one eye: what the CAVE's loops (headless and windows) draw once a frame.
#[derive(Clone, Copy, Debug)]
pub struct WallView {
    pub wall: usize,
    pub eye: &'static str,
    /// the eye's offset along the eye axis (-1/2 left, +1/2 right, 0 mono: `Wall::eyes`)
    pub side: f32,
}

impl WallView {
    /// `<wall>-<eye>`: the view's images and its columns in a session log are named so.
    pub fn name(&self, config: &crate::display::DisplayConfig) -> String {
        format!("{}-{}", config.walls[self.wall].name, self.eye)
    }
}

/// Every wall's eyes, in wall order.
pub fn wall_views(config: &crate::display::DisplayConfig) -> Vec<WallView> {
    (config.walls.iter().enumerate())
        .flat_map(|(wall, w)| {
            (w.eyes().into_iter()).map(move |(eye, side)| WallView { wall, eye, side })
        })
        .collect()
}

/// The reports' names of the views.
pub fn labels(config: &crate::display::DisplayConfig, views: &[WallView]) -> Vec<ViewLabel> {
    (views.iter())
        .map(|v| ViewLabel {
            wall: config.walls[v.wall].name.clone(),
            eye: v.eye,
            pixels: config.walls[v.wall].eye_pixels(),
        })
        .collect()
}

/// One view of a frame, as the reports name it.
#[derive(Clone, Debug)]
pub struct ViewLabel {
    pub wall: String,
    pub eye: &'static str,
    pub pixels: [u32; 2],
}
