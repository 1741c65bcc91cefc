//! Renders the first frame of a built-in scene once (counted, or timed with `--timing only`) on a
//! one-thread pool whose worker runs the whole render: under callgrind the passes' inclusive
//! instruction counts then hold every ray they trace (rayon runs a nested parallel loop inline on
//! its only worker). Prints each pass's rays, so instructions per ray are a pass's inclusive
//! count over them: `primary_pass` for camera rays, `shadow_passes` less `light_tracing` (the
//! order's preparation) for shadow rays.
//!
//! ```text
//! cargo build --release -p antumbra-cli --example pass_profile
//! valgrind --tool=callgrind --callgrind-out-file=cg.out \
//!   target/release/examples/pass_profile bedroom 20000 160x120 --build sah --width 2 --order fbto
//! callgrind_annotate --inclusive=yes cg.out | grep -E 'passes::(primary_pass|shadow_passes) |light_tracing '
//! ```

use antumbra_cli::example_args::{FrameArgs, FrameDefaults};
use antumbra_cli::method_args::MethodArgs;
use antumbra_core::render::Renderer;
use antumbra_core::scene::ImageSize;
use clap::Parser;

#[derive(Parser)]
struct Cli {
    #[command(flatten)]
    frame: FrameArgs,
    #[command(flatten)]
    method: MethodArgs,
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    let frame = cli.frame.open(FrameDefaults {
        scene: "bedroom",
        triangles: 20_000,
        size: ImageSize {
            width: 160,
            height: 120,
        },
    })?;
    let settings = cli.method.settings()?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let result = pool.install(|| Renderer::new().render(&frame.name, &frame.scene, &settings))?;
    for row in &result.stats {
        println!(
            "{:8} {:12} rays {:>8}  N_B {:>12}  N_T {:>12}",
            row.pass, row.light, row.rays, row.nb_per_ray, row.nt_per_ray
        );
    }
    Ok(())
}
