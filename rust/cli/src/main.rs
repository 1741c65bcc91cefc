//! `antumbra`: render shadow passes and traversal-work heat maps of animated scenes, and
//! benchmark the structures that trace them.

mod allocator;

use antumbra_cli::commands;
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "antumbra",
    version,
    about = "Shadow passes and BVH work heat maps of animated scenes"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render the default animated scene for a few frames: images, heat maps, statistics.
    Demo(commands::demo::DemoArgs),
    /// Render frames of a built-in scene or an OBJ/glTF file.
    Render(commands::render::RenderArgs),
    /// Write frames of a built-in scene or file as a recording (.antrec), the daemon's input.
    Record(commands::record::RecordArgs),
    /// Build time and Mrays/s per scene (primary and shadow rays, 1 thread and all threads).
    Bench(commands::bench::BenchArgs),
    /// Compare methods on the same frames: answers checked, work counted, time measured;
    /// a report folder with tables, plots and difference heat maps.
    Compare(commands::compare::CompareArgs),
    /// Sweep each knob (samples, resolution, sorting, SRDH, OSAH, splits, leaves, width) around
    /// its default: time against error or work, a Pareto plot per knob, a recommended value.
    Trade(commands::trade::TradeArgs),
    /// Run the daemon Blender talks to: a Unix socket (and optional loopback TCP), a spool
    /// folder for batch jobs.
    Serve(commands::serve::ServeArgs),
    /// Act on a spool folder's jobs: `resume` a job that ended in ERROR.
    Spool(commands::spool::SpoolArgs),
}

fn main() {
    allocator::keep_freed_memory();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Demo(a) => commands::demo::run(a),
        Command::Render(a) => commands::render::run(a),
        Command::Record(a) => commands::record::run(a),
        Command::Bench(a) => commands::bench::run(a),
        Command::Compare(a) => commands::compare::run(a),
        Command::Trade(a) => commands::trade::run(a),
        Command::Serve(a) => commands::serve::run(a, allocator::release_freed_memory),
        Command::Spool(a) => commands::spool::run(a),
    };
    if let Err(e) = result {
        eprintln!("antumbra: error: {e:#}");
        std::process::exit(1);
    }
}
