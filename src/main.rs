//! The `vlf` command line: the subcommands and their dispatch; each subcommand's arguments and
//! body are in `src/cli/<subcommand>.rs`. Library errors are reported through anyhow in the
//! binary (here and `src/cli/`), and only there.

mod cli;

use anyhow::Result;
use clap::{Parser, Subcommand};
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "vlf",
    version,
    about = "Virtual light field: propagate global illumination on the GPU, render any view from it"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Propagate a scene into a light field file (.vlf)
    Propagate(cli::propagate::PropagateArgs),
    /// Render a view from a scene (propagating first) or from a .vlf file
    Render(cli::render::RenderArgs),
    /// Path-trace a reference image with the same scene semantics (GPU, BVH, NEE + MIS)
    Reference(cli::reference::ReferenceArgs),
    /// Error against run time: the light field over a grid of settings and the path tracer over
    /// samples per pixel -> CSV + log-log chart with the Pareto front
    #[cfg(feature = "lab")]
    Sweep(cli::lab::SweepArgs),
    /// Draw every wall and eye of a display configuration (CAVE, power wall, window): one window
    /// per wall (W/A/S/D or arrows walk, Q/E turn, R/F rise/sink in fly mode, G toggles fly,
    /// left-drag turns, Home resets, gamepad sticks; Esc quits), or offscreen with --headless
    Cave(cli::cave::CaveArgs),
    /// Print a display configuration's live tracking as it arrives: head and wand poses in the
    /// room (after [tracking.calibration]), buttons and joystick
    Track(cli::track::TrackArgs),
    /// An OpenXR headset: the runtime's Vulkan device, a swapchain per eye, thumbstick navigation
    Xr(cli::xr::XrArgs),
    /// Write a procedural scene (scene.toml + OBJ + MTL, or glTF) that scales to a million triangles
    #[cfg(feature = "lab")]
    Generate(cli::lab::GenerateArgs),
    /// Run the stability cases and write their table (STABILITY.md)
    #[cfg(feature = "lab")]
    Stress(cli::lab::StressArgs),
    /// Compare a linear image with a reference: MSE, RMSE, relMSE, max error, display MSE, FLIP
    Compare(cli::compare::CompareArgs),
    /// Write the scene for another renderer, e.g. `vlf export mitsuba scene.toml -o DIR`: a
    /// standalone Mitsuba 3 scene (DIR/<camera>.xml per camera), for an independent ground truth
    Export(cli::export::ExportArgs),
    /// Propagate the built-in Cornell box and write PNG + EXR into out/
    Demo(cli::demo::DemoArgs),
    /// Check the light field on your own model: every camera rendered from it and path-traced
    /// by `vlf reference`, compared, with error maps and the verdict in words
    Verify(cli::verify::VerifyArgs),
    /// Draw a session log's frames (`vlf cave --headless --log DIR`) again, exactly as the run drew them: one folder of images per frame
    Replay(cli::replay::ReplayArgs),
    /// Measure setup, visibility, propagation and rendering
    #[cfg(feature = "lab")]
    Bench(cli::lab::BenchArgs),
}

fn main() {
    quiet_vulkan_device_select();
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    if !cfg!(feature = "lab") {
        refuse_lab_commands();
    }
    let cli = Cli::parse();
    if let Err(e) = run(cli) {
        eprintln!("error: {}", error_text(&e));
        std::process::exit(1);
    }
}

/// The lab's subcommands, which a core build (`--no-default-features`) leaves out.
const LAB_COMMANDS: [&str; 4] = ["bench", "generate", "stress", "sweep"];

/// In a build without the lab, `vlf bench` (or another lab command) says how to get it rather
/// than clap's bare "unrecognized subcommand".
fn refuse_lab_commands() {
    let asked = std::env::args().nth(1);
    if let Some(name) = asked.filter(|a| LAB_COMMANDS.contains(&a.as_str())) {
        eprintln!(
            "error: `vlf {name}` is part of the lab, which this vlf was built without \
             (--no-default-features): build it with `cargo build --release --features lab` \
             (the lab is a default feature)"
        );
        std::process::exit(2);
    }
}

/// Mesa's implicit Vulkan layer VK_LAYER_MESA_device_select asks the Wayland compositor for
/// the default GPU whenever physical devices are enumerated (wgpu enables the Wayland surface
/// extension); without a session, libwayland prints "error: XDG_RUNTIME_DIR is invalid or not
/// set in the environment." twice before every command. Where libwayland cannot connect
/// anyway (no WAYLAND_SOCKET, no absolute WAYLAND_DISPLAY, no absolute XDG_RUNTIME_DIR), the
/// layer has nothing to ask: switch it off with its own variable, unless the user set one of
/// its variables (NODEVICE_SELECT, MESA_VK_DEVICE_SELECT, DRI_PRIME). vlf chooses its adapter
/// itself (WGPU_ADAPTER_NAME); this runs first, before any thread exists.
fn quiet_vulkan_device_select() {
    let set = |k: &str| std::env::var_os(k).is_some_and(|v| !v.is_empty());
    let absolute =
        |k: &str| std::env::var_os(k).is_some_and(|v| v.to_string_lossy().starts_with('/'));
    let wayland_possible =
        set("WAYLAND_SOCKET") || absolute("WAYLAND_DISPLAY") || absolute("XDG_RUNTIME_DIR");
    let user_chose = ["NODEVICE_SELECT", "MESA_VK_DEVICE_SELECT", "DRI_PRIME"]
        .iter()
        .any(|k| std::env::var_os(k).is_some());
    if !wayland_possible && !user_chose {
        std::env::set_var("NODEVICE_SELECT", "1");
    }
}

/// The error and its causes on one line, each cause once: a library error that already
/// names its cause (`{path}: cannot read: {source}`) is not followed by that cause again.
fn error_text(e: &anyhow::Error) -> String {
    let mut text = e.to_string();
    for cause in e.chain().skip(1) {
        let cause = cause.to_string();
        if !text.contains(&cause) {
            text.push_str(": ");
            text.push_str(&cause);
        }
    }
    text
}

fn run(cli: Cli) -> Result<()> {
    let demo_default = || {
        Command::Demo(cli::demo::DemoArgs {
            out: PathBuf::from("out"),
        })
    };
    match cli.command.unwrap_or_else(demo_default) {
        Command::Propagate(a) => cli::propagate::run(a),
        Command::Render(a) => cli::render::run(a),
        Command::Reference(a) => cli::reference::run(a),
        Command::Cave(a) => cli::cave::run(a),
        Command::Track(a) => cli::track::run(a),
        Command::Xr(a) => cli::xr::run(a),
        Command::Compare(a) => cli::compare::run(a),
        Command::Export(a) => cli::export::run(a),
        Command::Demo(a) => cli::demo::run(&a.out),
        Command::Verify(a) => cli::verify::run(a),
        Command::Replay(a) => cli::replay::run(a),
        #[cfg(feature = "lab")]
        Command::Sweep(a) => cli::lab::sweep(a),
        #[cfg(feature = "lab")]
        Command::Generate(a) => cli::lab::generate(a),
        #[cfg(feature = "lab")]
        Command::Stress(a) => cli::lab::stress(a),
        #[cfg(feature = "lab")]
        Command::Bench(a) => cli::lab::bench(a),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_command_line_definition_is_consistent() {
        use clap::CommandFactory;
        super::Cli::command().debug_assert();
    }

    /// clap's own checks (`debug_assert`) are compiled out of release builds, which the tests
    /// run: the one that caught `vlf cave` (a positional and a flag sharing the id `config`, a
    /// panic in every debug build) is made here, for every subcommand.
    #[test]
    fn no_subcommand_has_two_arguments_of_one_id() {
        use clap::CommandFactory;
        let cli = super::Cli::command();
        for sub in cli.get_subcommands() {
            let mut ids: Vec<&str> = sub.get_arguments().map(|a| a.get_id().as_str()).collect();
            ids.sort_unstable();
            let twice: Vec<&&str> = (ids.windows(2))
                .filter(|w| w[0] == w[1])
                .map(|w| &w[0])
                .collect();
            assert!(
                twice.is_empty(),
                "vlf {}: argument ids {twice:?} are used twice",
                sub.get_name()
            );
        }
    }

    #[test]
    fn the_lab_commands_are_there_exactly_when_the_lab_is() {
        use clap::CommandFactory;
        let cli = super::Cli::command();
        for name in super::LAB_COMMANDS {
            let present = cli.find_subcommand(name).is_some();
            assert_eq!(present, cfg!(feature = "lab"), "vlf {name}");
        }
    }
}
