//! Running the trade: one knob's sweep as a comparison of its values ([`KnobSweep`]: work knobs'
//! answers checked against the default value's, image knobs' masks measured per light against
//! the reference), and every knob frame by frame ([`Trade`]), as a session runs it.

use serde::{Deserialize, Serialize};

use super::error::{mask_error, REFERENCE_SPP};
use super::knobs::{Knob, KnobKind, KnobValue, KNOBS};
use super::table::TradeRow;
use crate::cancel::CancelToken;
use crate::compare::{Comparison, FrameComparison, Mismatch, Step};
use crate::image::ImagePlane;
use crate::render::{RenderSettings, Renderer, StatsMode};
use crate::scene::Scene;
use crate::settings::NamedSettings;
use crate::{Error, Result};

/// A work knob's value whose answers differ from the default value's on a frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TradeMismatch {
    pub knob: String,
    pub mismatch: Mismatch,
}

impl std::fmt::Display for TradeMismatch {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(f, "knob '{}': {}", self.knob, self.mismatch)
    }
}

/// The image knobs' reference: the default value's method at [`REFERENCE_SPP`] and full size,
/// rendered by one renderer in the order the frames come (as a real animation).
#[derive(Clone)]
pub struct Reference {
    settings: RenderSettings,
    renderer: Renderer,
}

impl Reference {
    /// The reference of an image knob whose default value is `default`.
    pub fn of(default: &KnobValue, common: &NamedSettings) -> Result<Self> {
        let mut spec = default.spec.clone();
        spec.settings.insert("spp", i64::from(REFERENCE_SPP));
        let mut settings = spec.resolve(common)?;
        settings.stats = StatsMode::TimingOnly;
        Ok(Reference {
            settings,
            renderer: Renderer::new(),
        })
    }

    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// The reference's masks of `scene` (one per light).
    pub fn masks(
        &mut self,
        scene_name: &str,
        scene: &Scene,
        cancel: &CancelToken,
    ) -> Result<Vec<ImagePlane>> {
        let result = self
            .renderer
            .render_cancellable(scene_name, scene, &self.settings, cancel)
            .map_err(|e| match e {
                Error::Cancelled => Error::Cancelled,
                e => Error::invalid("the reference", e.to_string()),
            })?;
        Ok(result.masks)
    }
}

/// One knob's sweep: its values as the methods of a comparison (the default the baseline),
/// each keeping its state across frames.
#[derive(Clone)]
pub struct KnobSweep {
    knob: &'static Knob,
    values: Vec<KnobValue>,
    comparison: Comparison,
}

/// One knob's rows of one frame and its work values' answers that differ from the default's.
#[derive(Clone, Debug, Default)]
pub struct KnobFrame {
    pub rows: Vec<TradeRow>,
    pub mismatches: Vec<TradeMismatch>,
}

impl KnobSweep {
    /// `knob` over `values` (its table's when `None`, the default added when missing), every
    /// value checked before anything is rendered; `repeat` timed passes per value and frame.
    pub fn new(
        knob: &'static Knob,
        values: Option<&[String]>,
        common: &NamedSettings,
        repeat: usize,
    ) -> Result<Self> {
        let values = knob.sweep(values, common)?;
        let specs: Vec<_> = values.iter().map(|v| v.spec.clone()).collect();
        let default = &values.iter().find(|v| v.is_default).expect("a default");
        let comparison = Comparison::new(&specs, common, Some(&default.spec.label), repeat)
            .map_err(|e| Error::invalid(format!("knob '{}'", knob.name), e.to_string()))?;
        Ok(KnobSweep {
            knob,
            values,
            comparison,
        })
    }

    pub fn knob(&self) -> &'static Knob {
        self.knob
    }

    pub fn values(&self) -> &[KnobValue] {
        &self.values
    }

    /// The default value (the comparison's baseline).
    pub fn default_value(&self) -> &KnobValue {
        self.values
            .iter()
            .find(|v| v.is_default)
            .expect("a sweep holds its default value")
    }

    /// The resolved settings of each value, in order.
    pub fn settings(&self) -> Vec<&RenderSettings> {
        self.comparison.settings()
    }

    /// Method passes per frame (one counted and `repeat` timed per value).
    pub fn steps(&self) -> usize {
        self.comparison.steps()
    }

    /// Sweeps one frame, `full` at the full size; `reference` holds the reference's masks of
    /// this frame (image knobs). A frame that fails or is cancelled leaves every value's state
    /// as before it; an error names the knob (and the value, as the comparison names it).
    pub fn frame(
        &mut self,
        scene_name: &str,
        full: &Scene,
        reference: Option<&[ImagePlane]>,
        cancel: &CancelToken,
        progress: &mut (dyn FnMut(Step) + Send),
    ) -> Result<KnobFrame> {
        let scaled: Vec<Option<Scene>> = self
            .values
            .iter()
            .map(|v| (v.percentage != 100).then(|| at_percentage(full, v.percentage)))
            .collect();
        let scenes: Vec<&Scene> = scaled.iter().map(|s| s.as_ref().unwrap_or(full)).collect();
        let frame = self
            .comparison
            .frame_each_cancellable(scene_name, &scenes, cancel, progress)
            .map_err(|e| match e {
                Error::Cancelled => Error::Cancelled,
                e => Error::invalid(format!("knob '{}'", self.knob.name), e.to_string()),
            })?;
        let reference = reference.filter(|_| self.knob.kind == KnobKind::Image);
        let rows = rows(self.knob, &self.values, &self.comparison, &frame, reference);
        let mismatches = match self.knob.kind {
            KnobKind::Work => frame
                .mismatches
                .into_iter()
                .map(|mismatch| TradeMismatch {
                    knob: self.knob.name.to_string(),
                    mismatch,
                })
                .collect(),
            KnobKind::Image => Vec::new(),
        };
        Ok(KnobFrame { rows, mismatches })
    }
}

/// `scene` rendered at `percentage` of its size.
fn at_percentage(scene: &Scene, percentage: u32) -> Scene {
    let mut s = scene.clone();
    s.resolution.percentage = (s.resolution.percentage * percentage / 100).max(1);
    s
}

/// The frame's rows of every value; `reference` holds the reference masks of image knobs.
fn rows(
    knob: &Knob,
    values: &[KnobValue],
    comparison: &Comparison,
    frame: &FrameComparison,
    reference: Option<&[ImagePlane]>,
) -> Vec<TradeRow> {
    let specs = comparison.specs();
    let mut out = Vec::new();
    for ((value, spec), method) in values.iter().zip(specs).zip(&frame.methods) {
        let answers_equal = (knob.kind == KnobKind::Work)
            .then(|| !frame.mismatches.iter().any(|m| m.label == method.label));
        // Shadow rows come in the order of the masks (one per light).
        let mut shadow = 0;
        for row in &method.rows {
            let error = match reference {
                Some(reference) if row.stats.pass == "shadow" => {
                    let e = method.result.masks.get(shadow).zip(reference.get(shadow));
                    shadow += 1;
                    e.map(|(m, r)| mask_error(m, r))
                }
                _ => None,
            };
            out.push(TradeRow {
                knob: knob.name.to_string(),
                kind: knob.kind,
                value: value.value.clone(),
                is_default: value.is_default,
                settings: spec.to_string(),
                width: method.result.width,
                height: method.result.height,
                row: row.clone(),
                answers_equal,
                error,
            });
        }
    }
    out
}

/// A knob as a trade names it: the knob and its values (`None`: its table's).
pub type KnobChoice = (&'static Knob, Option<Vec<String>>);

/// `NAME` or `NAME=V1,V2,...` per knob (none: every knob), checked and resolved.
pub fn knob_choices<S: AsRef<str>>(texts: &[S]) -> Result<Vec<KnobChoice>> {
    if texts.is_empty() {
        return Ok(KNOBS.iter().map(|k| (k, None)).collect());
    }
    let mut out: Vec<KnobChoice> = Vec::new();
    for text in texts {
        let (k, values) = super::knobs::parse_knob_arg(text.as_ref())?;
        if out.iter().any(|(o, _)| o.name == k.name) {
            return Err(Error::invalid(
                "knob",
                format!("'{}' is given twice", k.name),
            ));
        }
        out.push((k, values));
    }
    Ok(out)
}

/// Every knob of a trade, frame by frame: each knob's sweep keeps its state across frames, and
/// the image knobs' reference is rendered once per frame.
#[derive(Clone)]
pub struct Trade {
    sweeps: Vec<KnobSweep>,
    reference: Option<Reference>,
    common: NamedSettings,
    repeat: usize,
}

/// One frame of every knob of a [`Trade`].
#[derive(Clone, Debug, Default)]
pub struct TradeFrame {
    pub frame: i32,
    /// Knob after knob, in the trade's order.
    pub rows: Vec<TradeRow>,
    pub mismatches: Vec<TradeMismatch>,
}

/// One pass of a [`Trade`]'s frame done: the reference's, or a method pass of a knob's value.
#[derive(Clone, Copy, Debug)]
pub struct TradeStep<'a> {
    /// `None`: the reference.
    pub knob: Option<&'a str>,
    pub done: usize,
    pub total: usize,
}

impl Trade {
    /// The knobs `choices` (see [`knob_choices`]) over the settings `common` every value shares.
    pub fn new(choices: &[KnobChoice], common: &NamedSettings, repeat: usize) -> Result<Self> {
        let sweeps = choices
            .iter()
            .map(|(k, values)| KnobSweep::new(k, values.as_deref(), common, repeat))
            .collect::<Result<Vec<_>>>()?;
        // One reference serves every image knob: the first's default method at full size.
        let reference = sweeps
            .iter()
            .find(|s| s.knob.kind == KnobKind::Image)
            .map(|s| Reference::of(s.default_value(), common))
            .transpose()?;
        Ok(Trade {
            sweeps,
            reference,
            common: common.clone(),
            repeat,
        })
    }

    /// The trade of `texts` (`NAME` or `NAME=V1,...`; none: every knob).
    pub fn parse<S: AsRef<str>>(
        texts: &[S],
        common: &NamedSettings,
        repeat: usize,
    ) -> Result<Self> {
        Self::new(&knob_choices(texts)?, common, repeat)
    }

    pub fn sweeps(&self) -> &[KnobSweep] {
        &self.sweeps
    }

    pub fn common(&self) -> &NamedSettings {
        &self.common
    }

    pub fn repeat(&self) -> usize {
        self.repeat
    }

    /// The resolved settings of every value of every knob, then the reference's.
    pub fn settings(&self) -> Vec<&RenderSettings> {
        let mut out: Vec<&RenderSettings> = self.sweeps.iter().flat_map(|s| s.settings()).collect();
        out.extend(self.reference.as_ref().map(|r| r.settings()));
        out
    }

    /// Passes per frame: the reference's (if any image knob), then every knob's method passes.
    pub fn steps(&self) -> usize {
        let sweeps = self.sweeps.iter().map(|s| s.steps());
        sweeps.fold(usize::from(self.reference.is_some()), usize::saturating_add)
    }

    /// Sweeps every knob over `scene`, calling `progress` after each pass. A frame that fails
    /// or is cancelled leaves every knob's state (and the reference's) as before it.
    pub fn frame(
        &mut self,
        scene_name: &str,
        scene: &Scene,
        cancel: &CancelToken,
        progress: &mut (dyn FnMut(TradeStep) + Send),
    ) -> Result<TradeFrame> {
        // Cloning shares the trees (reference counted): cheap next to a frame.
        let before = (self.sweeps.clone(), self.reference.clone());
        let result = self.run(scene_name, scene, cancel, progress);
        if result.is_err() {
            (self.sweeps, self.reference) = before;
        }
        result
    }

    fn run(
        &mut self,
        scene_name: &str,
        scene: &Scene,
        cancel: &CancelToken,
        progress: &mut (dyn FnMut(TradeStep) + Send),
    ) -> Result<TradeFrame> {
        let total = self.steps();
        let mut done = 0;
        let reference = match &mut self.reference {
            Some(r) => {
                let masks = r.masks(scene_name, scene, cancel)?;
                done += 1;
                progress(TradeStep {
                    knob: None,
                    done,
                    total,
                });
                Some(masks)
            }
            None => None,
        };
        let mut out = TradeFrame {
            frame: scene.frame,
            ..TradeFrame::default()
        };
        for sweep in &mut self.sweeps {
            let name = sweep.knob.name;
            let start = done;
            let knob_frame = sweep.frame(
                scene_name,
                scene,
                reference.as_deref(),
                cancel,
                &mut |s: Step| {
                    progress(TradeStep {
                        knob: Some(name),
                        done: start + s.done,
                        total,
                    })
                },
            )?;
            done = start + sweep.steps();
            out.rows.extend(knob_frame.rows);
            out.mismatches.extend(knob_frame.mismatches);
        }
        Ok(out)
    }
}
