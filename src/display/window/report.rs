//! What a windowed run measured, and its table.

use super::App;
use crate::display::frame::{frame_limits, Limit, ViewTiming};
use crate::stats::Distribution;

/// What a windowed run measured.
#[derive(Clone, Debug, serde::Serialize)]
pub struct WindowReport {
    pub display: String,
    pub adapter: String,
    pub windows: usize,
    pub frames: u32,
    pub views: Vec<ViewTiming>,
    pub cpu_frame_ms: Option<Distribution>,
    /// messages shown on screen (tracking gone quiet), in order
    pub status_messages: Vec<String>,
    /// live tracking: milliseconds from a pose's arrival to the submission of the first frame
    /// drawn from it (None without live tracking)
    pub tracking_latency_ms: Option<Distribution>,
    /// every timed frame's pose to submission and to predicted photons (`crate::study`)
    pub motion_to_photon: Option<crate::study::MotionToPhoton>,
    /// the frames judged by the limits (per-view and frame p99/p50, max/median, refresh)
    pub limits: Vec<Limit>,
    /// the settings every frame was drawn with, and with `fit_frame_time` what was probed
    pub quality: crate::render::budget::Quality,
    pub fit: Option<crate::render::budget::BudgetFit>,
    pub pacer: Option<crate::render::budget::PacerReport>,
}

impl App<'_> {
    pub(super) fn report(&self) -> WindowReport {
        let views = self.frame.times().views();
        let cpu_frame_ms = self.frame.times().cpu_ms();
        let limits = frame_limits(&views, cpu_frame_ms.as_ref(), self.config.frame_budget_ms());
        WindowReport {
            display: self.config.name.clone(),
            adapter: self.resident.ctx.summary.name.clone(),
            windows: self.windows.len(),
            frames: self.frames(),
            views,
            cpu_frame_ms,
            status_messages: self.status_messages.clone(),
            tracking_latency_ms: self.frame.latency_ms(),
            motion_to_photon: self.session.motion_to_photon(),
            limits,
            quality: self.frame.quality(),
            fit: self.frame.fit().cloned(),
            pacer: self.frame.pacer_report(),
        }
    }
}

impl WindowReport {
    pub fn table(&self) -> String {
        let mut s = format!(
            "  display {} on {}: {} window(s), {} frames timed, {}\n",
            self.display, self.adapter, self.windows, self.frames, self.quality
        );
        if let Some(fit) = &self.fit {
            s += &format!("  {}\n", fit.summary());
        }
        if let Some(p) = &self.pacer {
            s += &p.line();
        }
        for v in self.views.iter().filter(|v| v.gpu_ms.is_some()) {
            s.push_str(&v.row());
        }
        if let Some(d) = &self.cpu_frame_ms {
            s.push_str(&format!(
                "  CPU frame time (all windows presented): median {:.3} ms, p99 {:.3} ms\n",
                d.median, d.p99
            ));
        }
        if let Some(d) = &self.tracking_latency_ms {
            s.push_str(&format!("  tracking latency (pose received -> frame submitted): p50 {:.3} ms, p99 {:.3} ms ({} poses)\n", d.median, d.p99, d.samples));
        }
        if let Some(m) = &self.motion_to_photon {
            s.push_str(&m.line());
        }
        for m in &self.status_messages {
            s.push_str(&format!("  shown on screen: {m}\n"));
        }
        s.push_str(&Limit::lines(&self.limits));
        s
    }
}
