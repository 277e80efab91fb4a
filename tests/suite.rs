//! The benchmark suite end to end at quick settings on whatever adapter there is (timings on a
//! software adapter mean nothing; what is checked is that every scene runs, the report holds
//! every field, the targets are evaluated, the Markdown and the chart are written, and the
//! Markdown regenerated from the JSON is the same). Plus the generator's sizes.

use crate::common;
use common::*;
use vlf::lab::generate::{generate, GenerateOptions, SceneKind};

#[test]
fn generated_scenes_have_about_the_asked_size_and_load() {
    let dir = tempfile::tempdir().unwrap();
    for (kind, size, mirrors) in [
        (SceneKind::Classroom, 1_000u64, false),
        (SceneKind::Classroom, 100_000, true),
        (SceneKind::Gallery, 10_000, true),
    ] {
        let g = generate(
            &GenerateOptions {
                kind,
                size,
                mirrors,
                glossy: false,
            },
            &dir.path().join(format!("{kind:?}-{size}")),
        )
        .unwrap();
        let counted = if kind == SceneKind::Classroom {
            g.triangles
        } else {
            g.faces
        };
        println!(
            "{kind:?} {size}: {} triangles, {} faces",
            g.triangles, g.faces
        );
        assert!(
            (counted as f64 / size as f64 - 1.0).abs() < 0.35,
            "{kind:?} asked {size}, got {counted}"
        );
        let scene = vlf::scene::Scene::load(&g.scene).unwrap();
        let prepared = vlf::prepare::PreparedScene::new(&scene, 4.0).unwrap();
        assert_eq!(
            prepared.triangles.len() as u64,
            g.triangles,
            "every generated triangle survives import"
        );
        let mirror_faces = vlf::propagate::non_diffuse_faces(&prepared)
            .iter()
            .filter(|&&m| m)
            .count();
        assert_eq!(mirror_faces > 0, mirrors);
    }
}

/// Prints how long each case took (the test's output, where its time goes).
#[derive(Default)]
struct CaseTimes(std::sync::Mutex<Option<(std::time::Instant, String)>>);

impl vlf::progress::Progress for CaseTimes {
    fn begin(&self, _total: u64, _unit: &str, _message: &str) {}
    fn advance_to(&self, _done: u64, message: &str) {
        let mut last = self.0.lock().unwrap();
        if let Some((started, case)) = last.take() {
            println!("{:7.1} s  {case}", started.elapsed().as_secs_f64());
        }
        *last = Some((std::time::Instant::now(), message.to_string()));
    }
    fn note(&self, _line: &str) {}
    fn finish(&self) {
        if let Some((started, case)) = self.0.lock().unwrap().take() {
            println!("{:7.1} s  {case}", started.elapsed().as_secs_f64());
        }
    }
}

#[test]
fn quick_suite_runs_and_reports_every_scene() {
    let dir = tempfile::tempdir().unwrap();
    let root = repo_path("");
    let report =
        vlf::lab::suite::run(gpu(), &root, dir.path(), true, 1, &CaseTimes::default()).unwrap();
    let names: Vec<&str> = report.entries.iter().map(|e| e.name.as_str()).collect();
    println!("{names:?}");
    // quick: every case but the two boxes at the paper's settings
    assert!(names.len() >= 8, "{names:?}");
    assert!(!names.iter().any(|n| n.contains("paper")), "{names:?}");
    assert!(
        report.entries.iter().any(|e| e.direction_batches > 1),
        "the memory-budget run did not batch"
    );
    assert!(report.entries.iter().any(|e| e.non_diffuse_elements > 0));
    assert!(report.cost_slope.is_some_and(|s| s.is_finite()));
    assert_eq!(report.targets.len(), 5);
    // quick: the views drawn small at 1 eye ray per pixel, and the report says so
    assert_eq!(
        (report.views.eye_rays_per_pixel, report.views.size_divisor),
        (1, 4)
    );
    let json = dir.path().join("suite.json");
    std::fs::write(&json, serde_json::to_string_pretty(&report).unwrap()).unwrap();
    let again = vlf::lab::suite::SuiteReport::load(&json).unwrap();
    assert_eq!(again.markdown(), report.markdown());
    let md = report.markdown();
    println!("{md}");
    assert!(
        md.contains("### Targets")
            && md.contains("Atenea")
            && md.contains(&report.adapter.name)
            && md.contains("1 eye ray(s) per pixel and 1/4 of each side")
    );
    let chart = dir.path().join("suite.png");
    report.plot(&chart).unwrap();
    let img = image::open(&chart).unwrap();
    assert!(img.width() >= 1000);
}
