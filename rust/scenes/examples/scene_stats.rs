//! Prints each built-in scene's actual triangle count against its target, with the time to
//! build it and to produce a frame:
//! `cargo run --release -p antumbra-scenes --example scene_stats [targets...]`.

use std::time::Instant;

use antumbra_scenes::{builtin, SceneParams, BUILTIN_SCENES};

fn main() {
    let targets: Vec<usize> = {
        let args: Vec<usize> = std::env::args()
            .skip(1)
            .filter_map(|a| a.replace('_', "").parse().ok())
            .collect();
        if args.is_empty() {
            vec![10_000, 100_000, 350_000, 2_000_000]
        } else {
            args
        }
    };
    println!(
        "{:<10} {:>10} {:>10} {:>6} {:>9} {:>9} {:>8} {:>8}",
        "scene", "target", "actual", "ratio", "build ms", "frame ms", "meshes", "objects"
    );
    for name in BUILTIN_SCENES {
        for &triangles in &targets {
            let params = SceneParams {
                triangles,
                ..SceneParams::default()
            };
            let start = Instant::now();
            let anim = match builtin(name, &params) {
                Ok(a) => a,
                Err(e) => {
                    eprintln!("{name}: {e}");
                    continue;
                }
            };
            let build = start.elapsed();
            let start = Instant::now();
            let scene = anim.frame(2);
            let frame = start.elapsed();
            let actual = scene.triangle_count();
            println!(
                "{:<10} {:>10} {:>10} {:>6.2} {:>9.1} {:>9.1} {:>8} {:>8}",
                name,
                triangles,
                actual,
                actual as f64 / triangles as f64,
                build.as_secs_f64() * 1e3,
                frame.as_secs_f64() * 1e3,
                scene.meshes.len(),
                scene.objects.len()
            );
        }
    }
}
