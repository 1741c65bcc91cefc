//! One knob's sweep as a comparison of its values (the default value the baseline): work
//! knobs' answers checked against the default's; image knobs' masks measured per light against
//! the reference (spp 256, full resolution) rendered once per frame.

use antumbra_core::compare::{Comparison, FrameComparison, Mismatch};
use antumbra_core::image::ImagePlane;
use antumbra_core::render::{Renderer, StatsMode};
use antumbra_core::scene::Scene;
use antumbra_core::settings::NamedSettings;
use antumbra_core::trade::{mask_error, Knob, KnobKind, KnobValue, TradeRow, REFERENCE_SPP};
use anyhow::{Context, Result};

/// What the sweeps share: the scene's frames at full size, the shared settings, the timed
/// passes, and the image knobs' reference masks once rendered.
pub struct Sweeps<'a> {
    pub scene_name: &'a str,
    pub frames: &'a [Scene],
    pub common: &'a NamedSettings,
    pub repeat: usize,
    /// Per frame, the reference's masks (one per light).
    references: Option<Vec<Vec<ImagePlane>>>,
}

/// One knob's rows and the answers that differed from its default value's.
pub struct KnobSweep {
    pub rows: Vec<TradeRow>,
    pub mismatches: Vec<Mismatch>,
}

impl<'a> Sweeps<'a> {
    pub fn new(
        scene_name: &'a str,
        frames: &'a [Scene],
        common: &'a NamedSettings,
        repeat: usize,
    ) -> Self {
        Sweeps {
            scene_name,
            frames,
            common,
            repeat,
            references: None,
        }
    }

    /// Every frame's reference masks: `value`'s method at [`REFERENCE_SPP`] and full size,
    /// rendered in frame order by one renderer (as a real animation).
    fn references(&mut self, value: &KnobValue) -> Result<&[Vec<ImagePlane>]> {
        if self.references.is_none() {
            let mut spec = value.spec.clone();
            spec.settings.insert("spp", i64::from(REFERENCE_SPP));
            let mut settings = spec.resolve(self.common)?;
            settings.stats = StatsMode::TimingOnly;
            let mut renderer = Renderer::new();
            let mut out = Vec::with_capacity(self.frames.len());
            for scene in self.frames {
                let result = renderer
                    .render(self.scene_name, scene, &settings)
                    .with_context(|| format!("reference, frame {}", scene.frame))?;
                out.push(result.masks);
            }
            self.references = Some(out);
        }
        Ok(self.references.as_deref().unwrap_or_default())
    }

    /// Sweeps `knob` over `values`; `progress` is called after each frame.
    pub fn run(
        &mut self,
        knob: &Knob,
        values: &[KnobValue],
        progress: &mut dyn FnMut(i32),
    ) -> Result<KnobSweep> {
        let default = values
            .iter()
            .find(|v| v.is_default)
            .expect("a sweep holds its default value");
        if knob.kind == KnobKind::Image {
            self.references(default)?;
        }
        let specs: Vec<_> = values.iter().map(|v| v.spec.clone()).collect();
        let mut comparison =
            Comparison::new(&specs, self.common, Some(&default.spec.label), self.repeat)?;
        let mut out = KnobSweep {
            rows: Vec::new(),
            mismatches: Vec::new(),
        };
        for (i, full) in self.frames.iter().enumerate() {
            let scaled: Vec<Option<Scene>> = values
                .iter()
                .map(|v| (v.percentage != 100).then(|| at_percentage(full, v.percentage)))
                .collect();
            let scenes: Vec<&Scene> = scaled.iter().map(|s| s.as_ref().unwrap_or(full)).collect();
            let frame = comparison
                .frame_each(self.scene_name, &scenes)
                .with_context(|| format!("knob '{}', frame {}", knob.name, full.frame))?;
            let reference = match knob.kind {
                KnobKind::Image => self.references.as_ref().map(|r| &r[i][..]),
                KnobKind::Work => None,
            };
            out.rows
                .extend(rows(knob, values, &comparison, &frame, reference));
            if knob.kind == KnobKind::Work {
                out.mismatches.extend(frame.mismatches);
            }
            progress(full.frame);
        }
        Ok(out)
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
