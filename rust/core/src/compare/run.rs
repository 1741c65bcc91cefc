//! Runs several methods over the same frames, each keeping its own state across frames (so
//! OSAH from the previous frame and tree reuse behave as in a real animation): one counted pass
//! per method and frame for the work, whose answers are checked against the baseline's, then
//! `repeat` timed passes with counters compiled out, interleaved across methods (A B C A B C)
//! so that machine drift hits every method alike.

use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::method::MethodSpec;
use crate::cancel::CancelToken;
use crate::image::ImagePlane;
use crate::render::{FrameResult, RenderSettings, Renderer, StatsMode};
use crate::scene::Scene;
use crate::settings::NamedSettings;
use crate::stats::StatsRow;
use crate::{Error, Result};

/// A time measured `repeat` times: median and spread.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Timing {
    pub median: f64,
    pub min: f64,
    pub max: f64,
}

impl Timing {
    pub fn of(samples: &[f64]) -> Timing {
        if samples.is_empty() {
            return Timing::default();
        }
        let mut s = samples.to_vec();
        s.sort_by(f64::total_cmp);
        let n = s.len();
        let median = if n % 2 == 1 {
            s[n / 2]
        } else {
            0.5 * (s[n / 2 - 1] + s[n / 2])
        };
        Timing {
            median,
            min: s[0],
            max: s[n - 1],
        }
    }
}

/// One pass (primary, or one light's shadow pass) of one method on one frame: the counted
/// pass's statistics with its timing columns replaced by the medians of the timed passes.
/// Also the protocol's wire form (named MessagePack map, as [`StatsRow`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CompareRow {
    pub label: String,
    pub stats: StatsRow,
    pub build_ms: Timing,
    pub prepare_ms: Timing,
    pub trace_ms: Timing,
    /// The whole frame of this method (build, preparation, every pass, combine).
    pub frame_ms: Timing,
}

/// A method whose answers differ from the baseline's on a frame (also the wire form).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Mismatch {
    pub frame: i32,
    pub label: String,
    /// `light 'NAME'` or `primary hits`.
    pub what: String,
    pub pixels: usize,
    /// The method traced another scene structure than the baseline (two levels against the
    /// flat tree): instance transforms round differently from the flat set's, so rays through
    /// a triangle's edge may differ, and through alpha a hit's UV (and so its alpha) may differ
    /// in the last bits. Reported, never counted as a wrong answer.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub across_structures: bool,
}

impl Mismatch {
    /// Whether the method's answers are wrong (not an edge difference across structures).
    pub fn is_wrong(&self) -> bool {
        !self.across_structures
    }
}

impl std::fmt::Display for Mismatch {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        if self.across_structures {
            write!(
                f,
                "frame {}: method '{}' (another scene structure than the baseline's) differs \
                 where rounding does (triangle edges, alpha lookups) on {}: {} pixels",
                self.frame, self.label, self.what, self.pixels
            )
        } else {
            write!(
                f,
                "frame {}: method '{}' differs from the baseline on {}: {} pixels",
                self.frame, self.label, self.what, self.pixels
            )
        }
    }
}

/// One method's result on one frame.
pub struct MethodFrame {
    pub label: String,
    pub rows: Vec<CompareRow>,
    /// The counted pass's images (masks, heat maps, primary ids).
    pub result: FrameResult,
}

impl MethodFrame {
    /// Shadow-ray node visits per pixel (N_B summed over lights and samples): the plane the
    /// difference images subtract.
    pub fn shadow_heat(&self) -> Option<&ImagePlane> {
        self.result.heat.as_ref().map(|h| &h.shadow[0])
    }
}

/// One method pass of a frame done: `done` of `total` (see [`Comparison::steps`]).
#[derive(Clone, Copy, Debug)]
pub struct Step<'a> {
    pub label: &'a str,
    /// A timed pass (else the counted one).
    pub timed: bool,
    pub done: usize,
    pub total: usize,
}

/// Every method on one frame.
pub struct FrameComparison {
    pub frame: i32,
    pub methods: Vec<MethodFrame>,
    pub mismatches: Vec<Mismatch>,
}

#[derive(Clone)]
struct Method {
    spec: MethodSpec,
    settings: RenderSettings,
    renderer: Renderer,
}

/// The methods of a comparison and their state across frames (cloning copies the state, as
/// [`Renderer`] does: `antumbra trade` puts a frame's states back when a later knob fails).
#[derive(Clone)]
pub struct Comparison {
    methods: Vec<Method>,
    common: NamedSettings,
    baseline: usize,
    repeat: usize,
}

impl Comparison {
    /// `common` holds the settings every method shares (spp, seed); `baseline` is a label
    /// (default: the first method); `repeat` timed passes per method and frame (at least 1).
    pub fn new(
        specs: &[MethodSpec],
        common: &NamedSettings,
        baseline: Option<&str>,
        repeat: usize,
    ) -> Result<Self> {
        if specs.is_empty() {
            return Err(Error::invalid(
                "method",
                "a comparison needs at least one method",
            ));
        }
        if repeat == 0 {
            return Err(Error::invalid("repeat", "must be at least 1"));
        }
        let mut methods: Vec<Method> = Vec::new();
        for spec in specs {
            if methods.iter().any(|m| m.spec.label == spec.label) {
                return Err(Error::invalid(
                    "method",
                    format!("the label '{}' is used twice", spec.label),
                ));
            }
            methods.push(Method {
                settings: spec.resolve(common)?,
                spec: spec.clone(),
                renderer: Renderer::new(),
            });
        }
        let baseline = match baseline {
            None => 0,
            Some(label) => methods
                .iter()
                .position(|m| m.spec.label == label)
                .ok_or_else(|| {
                    Error::invalid(
                        "baseline",
                        format!("'{label}' is not the label of a method"),
                    )
                })?,
        };
        Ok(Comparison {
            methods,
            common: common.clone(),
            baseline,
            repeat,
        })
    }

    pub fn labels(&self) -> Vec<&str> {
        self.methods.iter().map(|m| m.spec.label.as_str()).collect()
    }

    pub fn specs(&self) -> Vec<&MethodSpec> {
        self.methods.iter().map(|m| &m.spec).collect()
    }

    /// The resolved settings of each method, in order.
    pub fn settings(&self) -> Vec<&RenderSettings> {
        self.methods.iter().map(|m| &m.settings).collect()
    }

    pub fn baseline(&self) -> &str {
        &self.methods[self.baseline].spec.label
    }

    /// The settings every method shares, as given.
    pub fn common(&self) -> &NamedSettings {
        &self.common
    }

    /// Timed passes per method and frame.
    pub fn repeat(&self) -> usize {
        self.repeat
    }

    /// Renders `scene` with every method: the counted pass (advancing each method's state),
    /// the check against the baseline, then the interleaved timed passes, each from a copy of
    /// the method's state before this frame so that it builds and prepares what the counted
    /// pass did.
    pub fn frame(&mut self, scene_name: &str, scene: &Scene) -> Result<FrameComparison> {
        self.frame_cancellable(scene_name, scene, &CancelToken::new(), &mut |_| {})
    }

    /// As [`Comparison::frame`], method `i` rendering `scenes[i]`: the same frame at another
    /// resolution (`antumbra trade`'s resolution scale). Masks of other sizes count as differing.
    pub fn frame_each(&mut self, scene_name: &str, scenes: &[&Scene]) -> Result<FrameComparison> {
        self.frame_each_cancellable(scene_name, scenes, &CancelToken::new(), &mut |_| {})
    }

    /// The method passes [`frame_cancellable`](Self::frame_cancellable) renders: one counted
    /// and `repeat` timed per method (saturating: admission sizes a request with it before
    /// its repeat count is known to be sane).
    pub fn steps(&self) -> usize {
        self.methods
            .len()
            .saturating_mul(self.repeat.saturating_add(1))
    }

    /// As [`frame`](Self::frame), reading `cancel` per tile of every pass and calling
    /// `progress` after each method pass. A frame that fails or is cancelled leaves every
    /// method's state as it was before the frame, so the next frame continues the animation.
    pub fn frame_cancellable(
        &mut self,
        scene_name: &str,
        scene: &Scene,
        cancel: &CancelToken,
        progress: &mut (dyn FnMut(Step) + Send),
    ) -> Result<FrameComparison> {
        self.frame_each_cancellable(
            scene_name,
            &vec![scene; self.methods.len()],
            cancel,
            progress,
        )
    }

    /// As [`frame_each`](Self::frame_each), cancellable as
    /// [`frame_cancellable`](Self::frame_cancellable).
    pub fn frame_each_cancellable(
        &mut self,
        scene_name: &str,
        scenes: &[&Scene],
        cancel: &CancelToken,
        progress: &mut (dyn FnMut(Step) + Send),
    ) -> Result<FrameComparison> {
        if scenes.len() != self.methods.len() {
            return Err(Error::invalid(
                "scenes",
                format!("{} scenes for {} methods", scenes.len(), self.methods.len()),
            ));
        }
        let before: Vec<Renderer> = self.methods.iter().map(|m| m.renderer.clone()).collect();
        let result = self.run(scene_name, scenes, &before, cancel, progress);
        if result.is_err() {
            for (m, state) in self.methods.iter_mut().zip(before) {
                m.renderer = state;
            }
        }
        result
    }

    /// Advances every method's state as [`frame_cancellable`](Self::frame_cancellable) would,
    /// each by a [`Renderer::warm_up`] (no shadow ray, row or check), calling `progress` after
    /// each method (of [`methods`](Self::labels)`.len()`). A warm-up that fails or is cancelled
    /// leaves every method's state as it was.
    pub fn warm_up_cancellable(
        &mut self,
        scene: &Scene,
        cancel: &CancelToken,
        progress: &mut (dyn FnMut(Step) + Send),
    ) -> Result<()> {
        let before: Vec<Renderer> = self.methods.iter().map(|m| m.renderer.clone()).collect();
        let total = self.methods.len();
        let mut warm = || {
            for (done, m) in self.methods.iter_mut().enumerate() {
                m.renderer
                    .warm_up_cancellable(scene, &m.settings, cancel)
                    .map_err(|e| in_method(&m.spec.label, e))?;
                progress(Step {
                    label: &m.spec.label,
                    timed: false,
                    done: done + 1,
                    total,
                });
            }
            Ok(())
        };
        let result = warm();
        if result.is_err() {
            for (m, state) in self.methods.iter_mut().zip(before) {
                m.renderer = state;
            }
        }
        result
    }

    fn run(
        &mut self,
        scene_name: &str,
        scenes: &[&Scene],
        before: &[Renderer],
        cancel: &CancelToken,
        progress: &mut (dyn FnMut(Step) + Send),
    ) -> Result<FrameComparison> {
        let total = self.steps();
        let mut done = 0;
        let mut counted = Vec::with_capacity(self.methods.len());
        for (m, scene) in self.methods.iter_mut().zip(scenes) {
            let settings = with_stats(&m.settings, StatsMode::Counts);
            counted.push(
                m.renderer
                    .render_cancellable(scene_name, scene, &settings, cancel)
                    .map_err(|e| in_method(&m.spec.label, e))?,
            );
            done += 1;
            progress(Step {
                label: &m.spec.label,
                timed: false,
                done,
                total,
            });
        }
        let frame = scenes.first().map_or(0, |s| s.frame);
        let mismatches = self.check(frame, &counted);
        let mut timed: Vec<Vec<(f64, Vec<StatsRow>)>> = vec![Vec::new(); self.methods.len()];
        for _ in 0..self.repeat {
            for (i, m) in self.methods.iter().enumerate() {
                let mut renderer = before[i].clone();
                let settings = with_stats(&m.settings, StatsMode::TimingOnly);
                let started = Instant::now();
                let result = renderer
                    .render_cancellable(scene_name, scenes[i], &settings, cancel)
                    .map_err(|e| in_method(&m.spec.label, e))?;
                let ms = started.elapsed().as_secs_f64() * 1e3;
                timed[i].push((ms, result.stats));
                done += 1;
                progress(Step {
                    label: &m.spec.label,
                    timed: true,
                    done,
                    total,
                });
            }
        }
        let methods = self
            .methods
            .iter()
            .zip(counted)
            .zip(timed)
            .map(|((m, result), timed)| MethodFrame {
                label: m.spec.label.clone(),
                rows: merge_rows(&m.spec.label, &result.stats, &timed),
                result,
            })
            .collect();
        Ok(FrameComparison {
            frame,
            methods,
            mismatches,
        })
    }

    /// Every method's masks and primary ids against the baseline's, bit for bit.
    fn check(&self, frame: i32, results: &[FrameResult]) -> Vec<Mismatch> {
        let base = &results[self.baseline];
        let mut out = Vec::new();
        for (m, r) in self.methods.iter().zip(results) {
            let across_structures = r.structure != base.structure;
            let mut differ = |what: String, pixels: usize| {
                if pixels > 0 {
                    out.push(Mismatch {
                        frame,
                        label: m.spec.label.clone(),
                        what,
                        pixels,
                        across_structures,
                    });
                }
            };
            for (a, b) in r.masks.iter().zip(&base.masks) {
                differ(format!("light '{}'", a.name), differing_pixels(a, b));
            }
            if r.masks.len() != base.masks.len() {
                differ(
                    "the number of lights".into(),
                    r.width as usize * r.height as usize,
                );
            }
            let ids = r
                .primary_hits
                .iter()
                .zip(&base.primary_hits)
                .filter(|(a, b)| a != b)
                .count()
                + r.primary_hits.len().abs_diff(base.primary_hits.len());
            differ("primary hits".into(), ids);
        }
        out
    }
}

fn with_stats(settings: &RenderSettings, stats: StatsMode) -> RenderSettings {
    RenderSettings {
        stats,
        ..settings.clone()
    }
}

/// A method's error, naming the method; a cancelled frame stays [`Error::Cancelled`].
fn in_method(label: &str, e: Error) -> Error {
    match e {
        Error::Cancelled => Error::Cancelled,
        e => Error::invalid(format!("method '{label}'"), e.to_string()),
    }
}

/// Pixels whose values differ in their bits (so -0 and 0, or two NaNs of other payloads, count).
fn differing_pixels(a: &ImagePlane, b: &ImagePlane) -> usize {
    a.data
        .iter()
        .zip(&b.data)
        .filter(|(x, y)| x.to_bits() != y.to_bits())
        .count()
        + a.data.len().abs_diff(b.data.len())
}

/// The counted rows with the timed passes' medians in their timing columns. The timed passes
/// produce the same rows in the same order (same passes, same lights).
fn merge_rows(
    label: &str,
    counted: &[StatsRow],
    timed: &[(f64, Vec<StatsRow>)],
) -> Vec<CompareRow> {
    let frame_ms = Timing::of(&timed.iter().map(|(ms, _)| *ms).collect::<Vec<_>>());
    counted
        .iter()
        .enumerate()
        .map(|(i, row)| {
            let column = |f: fn(&StatsRow) -> f64| {
                Timing::of(
                    &timed
                        .iter()
                        .filter_map(|(_, rows)| rows.get(i).map(f))
                        .collect::<Vec<_>>(),
                )
            };
            let build_ms = column(|r| r.build_ms);
            let prepare_ms = column(|r| r.prepare_ms);
            let trace_ms = column(|r| r.trace_ms);
            let mut stats = row.clone();
            stats.build_ms = build_ms.median;
            stats.prepare_ms = prepare_ms.median;
            stats.set_timing(trace_ms.median, true);
            CompareRow {
                label: label.to_string(),
                stats,
                build_ms,
                prepare_ms,
                trace_ms,
                frame_ms,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medians_and_spread() {
        let t = Timing::of(&[3.0, 1.0, 2.0]);
        assert_eq!((t.median, t.min, t.max), (2.0, 1.0, 3.0));
        assert_eq!(Timing::of(&[4.0, 1.0, 2.0, 3.0]).median, 2.5);
        assert_eq!(Timing::of(&[]), Timing::default());
    }
}
