//! Whether a request may start, decided from its sizes before any work or allocation: its repeat
//! count, its method passes against [`Limits::max_request_passes`] and its estimated peak memory
//! against [`Limits::max_render_bytes`]. The daemon's `Render`, `Compare` and `Trade`, the
//! spool's frames and `antumbra render`, `compare` and `trade` all call these functions, so a
//! request refused by one is refused by every one, with the same message.

use antumbra_core::compare::Comparison;
use antumbra_core::render::{
    estimate_comparison_bytes, estimate_render_bytes, RenderMemory, RenderSettings,
};
use antumbra_core::scene::Scene;
use antumbra_core::trade::Trade;

use crate::check::check_repeat;
use crate::error::ProtocolError;
use crate::limits::Limits;

/// What one request asks for: `frames` frames (1 for a daemon request; a command-line run's
/// or spool job's frame count) of `scene`, `what` naming it in messages (e.g. `Compare frame
/// 3`, `compare of frames 1-24`).
#[derive(Clone, Copy, Debug)]
pub struct Asked<'a> {
    pub what: &'a str,
    pub scene: &'a Scene,
    pub frames: u64,
}

/// Admits a render of `settings` copying `output_planes` planes out of each frame's result:
/// one pass per frame within the pass bound, the frame within the memory budget.
pub fn admit_render(
    asked: Asked,
    settings: &RenderSettings,
    output_planes: u64,
    limits: &Limits,
) -> Result<RenderMemory, ProtocolError> {
    check_passes(asked, 1, || "1 render".into(), limits)?;
    let estimate = estimate_render_bytes(asked.scene, settings, output_planes);
    if estimate.total() > limits.max_render_bytes {
        return Err(ProtocolError::RenderMemory {
            frame: asked.scene.frame,
            estimate: Box::new(estimate),
            limit: limits.max_render_bytes,
        });
    }
    Ok(estimate)
}

/// Admits a comparison (each method copying its heat plane out when `images`): its repeat
/// count, its method passes, and every method's trees, results and prepass together
/// ([`estimate_comparison_bytes`]).
pub fn admit_compare(
    asked: Asked,
    comparison: &Comparison,
    images: bool,
    limits: &Limits,
) -> Result<RenderMemory, ProtocolError> {
    let methods = comparison.settings();
    let repeat = comparison.repeat() as u64;
    check_repeat(|| format!("{}: repeat", asked.what), repeat)?;
    let per_frame = || format!("{} methods x (1 counted + {repeat} timed)", methods.len());
    check_passes(asked, comparison.steps() as u64, per_frame, limits)?;
    let estimate = estimate_comparison_bytes(asked.scene, &methods, u64::from(images));
    if estimate.total() > limits.max_render_bytes {
        return Err(ProtocolError::CompareMemory {
            frame: asked.scene.frame,
            methods: methods.len(),
            estimate: Box::new(estimate),
            limit: limits.max_render_bytes,
        });
    }
    Ok(estimate)
}

/// Admits a trade: its repeat count, its passes (every knob value's and the reference's) and
/// every value's state and the reference's together.
pub fn admit_trade(
    asked: Asked,
    trade: &Trade,
    limits: &Limits,
) -> Result<RenderMemory, ProtocolError> {
    let values = trade.settings();
    let repeat = trade.repeat() as u64;
    check_repeat(|| format!("{}: repeat", asked.what), repeat)?;
    let per_frame = || {
        let knob_values: usize = trade.sweeps().iter().map(|s| s.values().len()).sum();
        let reference = values.len().saturating_sub(knob_values);
        format!("{knob_values} knob values x (1 counted + {repeat} timed) + {reference} reference")
    };
    check_passes(asked, trade.steps() as u64, per_frame, limits)?;
    let estimate = estimate_comparison_bytes(asked.scene, &values, 0);
    if estimate.total() > limits.max_render_bytes {
        return Err(ProtocolError::TradeMemory {
            frame: asked.scene.frame,
            values: values.len(),
            estimate: Box::new(estimate),
            limit: limits.max_render_bytes,
        });
    }
    Ok(estimate)
}

/// `per_frame` passes (described by `shape`) times the request's frames against
/// `max_request_passes`.
fn check_passes(
    asked: Asked,
    per_frame: u64,
    shape: impl FnOnce() -> String,
    limits: &Limits,
) -> Result<(), ProtocolError> {
    let passes = per_frame.saturating_mul(asked.frames);
    if passes > limits.max_request_passes {
        return Err(ProtocolError::RequestPasses {
            what: asked.what.to_string(),
            per_frame: shape(),
            frames: asked.frames,
            passes,
            limit: limits.max_request_passes,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use antumbra_core::compare::MethodSpec;
    use antumbra_core::settings::NamedSettings;
    use antumbra_core::trade::knob_choices;

    fn scene(width: u32, height: u32) -> Scene {
        use antumbra_core::scene::{Camera, Light, LightKind, Mesh, Object, Resolution};
        use glam::{DMat4, DVec3};
        let mesh = Mesh::new(
            "tri",
            vec![
                [0.0, 0.0, 0.0].into(),
                [1.0, 0.0, 0.0].into(),
                [0.0, 1.0, 0.0].into(),
            ],
            vec![[0, 1, 2]],
        );
        Scene {
            frame: 1,
            meshes: vec![std::sync::Arc::new(mesh)],
            objects: vec![Object::new("o", 0, DMat4::IDENTITY)],
            camera: Camera::look_at(DVec3::new(0.0, -5.0, 2.0), DVec3::ZERO, DVec3::Z),
            lights: vec![Light::new(
                "sun",
                DMat4::IDENTITY,
                LightKind::Sun { angle: 0.0 },
            )],
            resolution: Resolution::new(width, height),
            alpha: Default::default(),
        }
    }

    fn comparison(methods: usize, repeat: usize) -> Comparison {
        let specs: Vec<MethodSpec> = (0..methods)
            .map(|i| format!("m{i}=width=2").parse().unwrap())
            .collect();
        Comparison::new(&specs, &NamedSettings::new(), None, repeat).unwrap()
    }

    #[test]
    fn a_comparisons_images_grow_linearly_with_its_methods() {
        // Issue 33: 1,000 methods at 64x48 with images were estimated at 26.6 GiB (each
        // method's estimate counted every method's heat plane); in-process they peak at 344 MB.
        let sc = scene(64, 48);
        let request = Asked {
            what: "Compare frame 1",
            scene: &sc,
            frames: 1,
        };
        let limits = Limits::default();
        let estimate = |n, images| {
            admit_compare(request, &comparison(n, 1), images, &limits)
                .unwrap()
                .total()
        };
        let (small, big) = (estimate(100, true), estimate(1000, true));
        assert!(
            big < 1 << 30,
            "{}",
            antumbra_core::render::format_bytes(big)
        );
        // Ten times the methods: at most ten times the memory (linear, the process once).
        assert!(big <= 10 * small, "{big} vs {small}");
        assert!(estimate(1000, true) > estimate(1000, false));
    }

    #[test]
    fn passes_and_repeat_are_bounded_with_their_own_messages() {
        let sc = scene(32, 24);
        let limits = Limits::default();
        let request = |frames| Asked {
            what: "compare of frames 1-2147483647",
            scene: &sc,
            frames,
        };
        let e =
            admit_compare(request(i32::MAX as u64), &comparison(5, 1), false, &limits).unwrap_err();
        let text = e.to_string();
        assert!(
            text.starts_with("compare of frames 1-2147483647: 21474836470 passes (5 methods x (1 counted + 1 timed) per frame, x 2147483647 frames)")
                && text.contains("limit of 100000 passes per request (max_request_passes)"),
            "{text}"
        );
        assert_eq!(e.code(), crate::ErrorCode::LimitExceeded);
        // At the limit: admitted.
        let at = limits.max_request_passes / 10;
        assert!(admit_compare(request(at), &comparison(5, 1), false, &limits).is_ok());
        assert!(admit_compare(request(at + 1), &comparison(5, 1), false, &limits).is_err());
        // The repeat count first: its steps would not fit a usize.
        let e = admit_compare(request(1), &comparison(1, usize::MAX), false, &limits)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(
                "repeat: 18446744073709551615 exceeds the limit of 100 (max_compare_repeat)"
            ),
            "{e}"
        );
        let trade = Trade::new(
            &knob_choices(&["spp=1,2,3"]).unwrap(),
            &NamedSettings::new(),
            3,
        )
        .unwrap();
        let tiny = Limits {
            max_request_passes: 10,
            ..Limits::default()
        };
        let e = admit_trade(request(1), &trade, &tiny)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("17 passes (4 knob values x (1 counted + 3 timed) + 1 reference per frame, x 1 frame)"),
            "{e}"
        );
        let e = admit_render(request(11), &RenderSettings::default(), 0, &tiny)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("11 passes (1 render per frame, x 11 frames)"),
            "{e}"
        );
    }
}
