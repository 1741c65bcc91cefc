//! The knobs `antumbra trade` sweeps, defined once: each knob's name, what it trades, the method
//! it varies from, the setting (or order option, or resolution) it sets and the values it takes.

use serde::{Deserialize, Serialize};

use crate::compare::MethodSpec;
use crate::render::RenderSettings;
use crate::settings::{setting, NamedSettings};
use crate::{Error, Result};

/// Whether a knob changes the image (measured against a reference) or only the work.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum KnobKind {
    Image,
    Work,
}

impl KnobKind {
    pub fn name(self) -> &'static str {
        match self {
            KnobKind::Image => "image",
            KnobKind::Work => "work",
        }
    }
}

/// What a knob's value sets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target {
    /// A render setting of the schema, by its name.
    Setting(&'static str),
    /// An option of the base method's order (`sorted:budget=V`); `unset` is the value word that
    /// leaves the option out (the order's own default, e.g. `depth` unlimited).
    OrderOption {
        option: &'static str,
        unset: Option<&'static str>,
    },
    /// The image size in percent of the full resolution (the scene's `resolution_percentage`).
    Resolution,
}

/// One knob of the trade.
#[derive(Debug)]
pub struct Knob {
    pub name: &'static str,
    pub kind: KnobKind,
    /// What it trades, in one line (trade.md and docs/trade.md).
    pub trades: &'static str,
    /// The method it varies from, as `NAME=VALUE,...` with the settings' own names.
    pub base: &'static str,
    pub target: Target,
    /// The values swept, around the default (which is added when missing).
    pub values: &'static [&'static str],
}

/// The full resolution, in percent: the image knobs' reference and the resolution's default.
pub const FULL_RESOLUTION: u32 = 100;

const SORTED8: &str = "build=sah,width=8,order=sorted";
const SRDH: &str = "build=sah,width=2,order=srdh";
const OSAH8: &str = "build=osah,width=8,order=sorted";
const SBVH8: &str = "build=sbvh,width=8,order=sorted";

pub static KNOBS: &[Knob] = &[
    Knob {
        name: "spp",
        kind: KnobKind::Image,
        trades: "shadow rays of soft lights against noise in their masks",
        base: SORTED8,
        target: Target::Setting("spp"),
        values: &["1", "2", "4", "8", "16", "32", "64"],
    },
    Knob {
        name: "resolution",
        kind: KnobKind::Image,
        trades: "pixels (all rays) against detail lost by upsampling the masks",
        base: SORTED8,
        target: Target::Resolution,
        values: &["25", "50", "75", "100"],
    },
    Knob {
        name: "transparent_bounces",
        kind: KnobKind::Image,
        trades: "transparent hits a shadow ray passes (Cycles' Transparent bounces) against shadows too dark behind layers of leaves",
        base: SORTED8,
        target: Target::Setting("transparent_bounces"),
        values: &["1", "2", "4", "8", "16", "64"],
    },
    Knob {
        name: "alpha",
        kind: KnobKind::Image,
        trades: "alpha-textured cards cast whole (no alpha lookups) against light through their transparent parts",
        base: SORTED8,
        target: Target::Setting("alpha"),
        values: &["false", "true"],
    },
    Knob {
        name: "sort_budget",
        kind: KnobKind::Work,
        trades: "representative rays traced to sort a light's tree against a better order",
        base: SORTED8,
        target: Target::OrderOption {
            option: "budget",
            unset: None,
        },
        values: &["0.005", "0.01", "0.02", "0.05", "0.1", "0.2"],
    },
    Knob {
        name: "sort_depth",
        kind: KnobKind::Work,
        trades: "sorting only the top levels (cheaper) against sorting every node",
        base: SORTED8,
        target: Target::OrderOption {
            option: "depth",
            unset: Some("all"),
        },
        values: &["2", "4", "6", "8", "12", "all"],
    },
    Knob {
        name: "srdh_rays",
        kind: KnobKind::Work,
        trades: "representative rays (a prepass grid or a share of the pixels) against SRDH tree quality",
        base: SRDH,
        target: Target::OrderOption {
            option: "rays",
            unset: None,
        },
        values: &["4x4", "8x8", "16x16", "32x32", "0.01", "0.05"],
    },
    Knob {
        name: "srdh_bins",
        kind: KnobKind::Work,
        trades: "SRDH build time against its split quality",
        base: SRDH,
        target: Target::OrderOption {
            option: "bins",
            unset: None,
        },
        values: &["4", "8", "16", "32", "64"],
    },
    Knob {
        name: "visibility",
        kind: KnobKind::Work,
        trades: "an exact visible set (a second primary pass) or a prepass against last frame's",
        base: OSAH8,
        target: Target::Setting("visibility"),
        values: &["previous", "exact", "prepass:16x16", "prepass:64x64"],
    },
    Knob {
        name: "osah_w",
        kind: KnobKind::Work,
        trades: "OSAH's weight of visible triangles against plain SAH",
        base: OSAH8,
        target: Target::Setting("osah_w"),
        values: &["0.1", "0.3", "0.5", "0.7", "0.9", "0.99"],
    },
    Knob {
        name: "spatial_splits",
        kind: KnobKind::Work,
        trades: "spatial splits' build time and references against traversal work",
        base: SBVH8,
        target: Target::Setting("spatial_splits"),
        values: &["false", "true"],
    },
    Knob {
        name: "split_alpha",
        kind: KnobKind::Work,
        trades: "trying spatial splits at fewer nodes (overlap gate) against their benefit",
        base: SBVH8,
        target: Target::Setting("split_alpha"),
        values: &["0", "0.00001", "0.0001", "0.001", "0.01", "1"],
    },
    Knob {
        name: "split_node_overlap",
        kind: KnobKind::Work,
        trades: "Embree's per-node overlap gate on spatial splits against their benefit",
        base: SBVH8,
        target: Target::Setting("split_node_overlap"),
        values: &["0", "0.01", "0.05", "0.1", "0.3"],
    },
    Knob {
        name: "split_min_refs",
        kind: KnobKind::Work,
        trades: "no spatial splits in small nodes (faster build) against their benefit",
        base: SBVH8,
        target: Target::Setting("split_min_refs"),
        values: &["0", "16", "64", "256", "1024"],
    },
    Knob {
        name: "max_growth",
        kind: KnobKind::Work,
        trades: "more references from spatial splits against memory and build time",
        base: SBVH8,
        target: Target::Setting("max_growth"),
        values: &["0.1", "0.25", "0.5", "1", "2"],
    },
    Knob {
        name: "min_leaf_size",
        kind: KnobKind::Work,
        trades: "leaves made without a split search (faster build) against tree quality",
        base: SORTED8,
        target: Target::Setting("min_leaf_size"),
        values: &["1", "2", "4", "8"],
    },
    Knob {
        name: "width",
        kind: KnobKind::Work,
        trades: "children per node: fewer, wider node visits against more box tests per visit",
        base: "build=sah,order=sorted",
        target: Target::Setting("width"),
        values: &["2", "4", "8"],
    },
    Knob {
        name: "collapse",
        kind: KnobKind::Work,
        trades: "the SAH-optimal wide collapse against the greedy one's cheaper build",
        base: SORTED8,
        target: Target::Setting("collapse"),
        values: &["sah", "greedy"],
    },
];

/// The knob table as Markdown (docs/trade.md holds it between `<!-- knobs -->` markers).
pub fn knobs_markdown() -> String {
    let mut s = String::from(
        "| knob | kind | varies from | values (default in bold) | trades |\n|---|---|---|---|---|\n",
    );
    let none = NamedSettings::new();
    for k in KNOBS {
        let values: Vec<String> = k
            .sweep(None, &none)
            .expect("the knob table sweeps")
            .iter()
            .map(|v| {
                if v.is_default {
                    format!("**{}**", v.value)
                } else {
                    v.value.clone()
                }
            })
            .collect();
        let what = match k.target {
            Target::Setting(name) => format!("`{name}`"),
            Target::OrderOption { option, .. } => format!("order option `{option}`"),
            Target::Resolution => "% of the full size".into(),
        };
        s += &format!(
            "| `{}` | {} | `{}` | {}: {} | {} |\n",
            k.name,
            k.kind.name(),
            k.base,
            what,
            values.join(", "),
            k.trades
        );
    }
    s
}

/// The names of every knob, for error messages and help.
pub fn knob_names() -> Vec<&'static str> {
    KNOBS.iter().map(|k| k.name).collect()
}

/// The knob called `name`, or an error listing the knobs.
pub fn knob(name: &str) -> Result<&'static Knob> {
    KNOBS.iter().find(|k| k.name == name).ok_or_else(|| {
        Error::invalid(
            "knob",
            format!(
                "'{name}' is not a knob (knobs: {})",
                knob_names().join(", ")
            ),
        )
    })
}

/// One value of a knob as a method of its sweep.
#[derive(Clone, Debug)]
pub struct KnobValue {
    /// As typed: `0.5`, `prepass:16x16`, `all`.
    pub value: String,
    /// The method: labelled by the value (characters a label may not hold become `-`).
    pub spec: MethodSpec,
    /// Image size in percent of the full resolution.
    pub percentage: u32,
    pub is_default: bool,
}

/// `value` as a method label: letters, digits, `-`, `_`, `.`.
fn label_of(value: &str) -> String {
    value
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') {
                c
            } else {
                '-'
            }
        })
        .collect()
}

impl Knob {
    /// The base method's settings (the knob's own value left at its default).
    fn base_settings(&self) -> NamedSettings {
        let spec: MethodSpec = format!("base={}", self.base)
            .parse()
            .expect("the knob table's base methods parse");
        spec.settings
    }

    fn invalid(&self, message: String) -> Error {
        Error::invalid(format!("knob '{}'", self.name), message)
    }

    /// The default value: the shared setting if one is given in `common`, else the schema's (or
    /// the order's) default, read from the resolved base method.
    pub fn default_value(&self, common: &NamedSettings) -> Result<String> {
        let base = MethodSpec::new("base", self.base_settings())?.resolve(common)?;
        Ok(match self.target {
            Target::Setting(name) => {
                let s = setting(name).expect("the knob table names settings of the schema");
                (s.get)(&base).to_string()
            }
            Target::OrderOption { option, unset } => {
                let order = base.shadow_order.to_string();
                order
                    .split(':')
                    .skip(1)
                    .find_map(|kv| kv.strip_prefix(option)?.strip_prefix('='))
                    .map(str::to_string)
                    .or(unset.map(str::to_string))
                    .ok_or_else(|| {
                        self.invalid(format!("the order '{order}' has no option '{option}'"))
                    })?
            }
            Target::Resolution => FULL_RESOLUTION.to_string(),
        })
    }

    /// The method of `value`: the base method, the shared settings of `common` under it.
    fn method(&self, value: &str, common: &NamedSettings) -> Result<(MethodSpec, u32)> {
        self.method_of(value, common).map_err(|e| match e {
            Error::Invalid { ref field, .. } if field.starts_with("knob '") => e,
            e => self.invalid(format!("value '{value}': {e}")),
        })
    }

    fn method_of(&self, value: &str, common: &NamedSettings) -> Result<(MethodSpec, u32)> {
        let mut settings = self.base_settings();
        let mut percentage = FULL_RESOLUTION;
        match self.target {
            Target::Setting(name) => {
                let s = setting(name).expect("the knob table names settings of the schema");
                settings.insert(name, s.parse(value)?);
            }
            Target::OrderOption { option, unset } => {
                let order = settings
                    .get("order")
                    .expect("an order knob's base names its order")
                    .to_string();
                let order = if Some(value) == unset {
                    order
                } else {
                    format!("{order}:{option}={value}")
                };
                settings.insert("order", setting("order").unwrap().parse(&order)?);
            }
            Target::Resolution => {
                percentage = value
                    .parse()
                    .ok()
                    .filter(|p| (1..=FULL_RESOLUTION).contains(p))
                    .ok_or_else(|| {
                        self.invalid(format!(
                            "resolution is a percentage in 1..=100, got '{value}'"
                        ))
                    })?;
            }
        }
        let spec = MethodSpec::new(&label_of(value), settings)?;
        spec.resolve(common)?;
        Ok((spec, percentage))
    }

    /// The sweep: `values` (the table's when `None`), plus the default when missing; the value
    /// whose resolved settings and size equal the default's is marked as the default.
    pub fn sweep(
        &self,
        values: Option<&[String]>,
        common: &NamedSettings,
    ) -> Result<Vec<KnobValue>> {
        let texts: Vec<String> = match values {
            Some(v) => v.to_vec(),
            None => self.values.iter().map(|v| v.to_string()).collect(),
        };
        let default = self.default_value(common)?;
        let (default_spec, default_pct) = self.method(&default, common)?;
        let resolved = |spec: &MethodSpec| -> Result<RenderSettings> { spec.resolve(common) };
        let default_settings = resolved(&default_spec)?;
        let mut out = Vec::new();
        for value in &texts {
            let (spec, percentage) = self.method(value, common)?;
            if out.iter().any(|v: &KnobValue| v.spec.label == spec.label) {
                return Err(self.invalid(format!("the value '{value}' is given twice")));
            }
            let is_default = percentage == default_pct && resolved(&spec)? == default_settings;
            out.push(KnobValue {
                value: value.clone(),
                spec,
                percentage,
                is_default,
            });
        }
        if !out.iter().any(|v| v.is_default) {
            out.push(KnobValue {
                value: default,
                spec: default_spec,
                percentage: default_pct,
                is_default: true,
            });
        }
        Ok(out)
    }
}

/// `NAME` or `NAME=V1,V2,...` as `--knob` takes it.
pub fn parse_knob_arg(text: &str) -> Result<(&'static Knob, Option<Vec<String>>)> {
    match text.split_once('=') {
        None => Ok((knob(text.trim())?, None)),
        Some((name, values)) => {
            let k = knob(name.trim())?;
            let values: Vec<&str> = values.split(',').map(str::trim).collect();
            // An empty value is a typo (`1,,4`), refused rather than skipped; the message names
            // its place, not the text, which may be long.
            if let Some(i) = values.iter().position(|v| v.is_empty()) {
                return Err(k.invalid(format!(
                    "value {} of {} is empty (values are V1,V2,...)",
                    i + 1,
                    values.len()
                )));
            }
            Ok((k, Some(values.into_iter().map(String::from).collect())))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_knob_sweeps_with_its_default_marked_once() {
        for k in KNOBS {
            let sweep = k.sweep(None, &NamedSettings::new()).unwrap();
            let defaults: Vec<&str> = sweep
                .iter()
                .filter(|v| v.is_default)
                .map(|v| v.value.as_str())
                .collect();
            assert_eq!(defaults.len(), 1, "{}: {defaults:?}", k.name);
            assert_eq!(
                sweep.len(),
                k.values.len(),
                "{}: default not among the values",
                k.name
            );
        }
    }

    #[test]
    fn defaults_come_from_the_schema_and_the_orders() {
        let none = NamedSettings::new();
        let d = |n: &str| knob(n).unwrap().default_value(&none).unwrap();
        assert_eq!(d("spp"), "4");
        assert_eq!(d("osah_w"), "0.9");
        assert_eq!(d("sort_budget"), "0.05");
        assert_eq!(d("sort_depth"), "all");
        assert_eq!(d("srdh_rays"), "16x16");
        assert_eq!(d("srdh_bins"), "32");
        assert_eq!(d("resolution"), "100");
        let common = NamedSettings::new().with("spp", 16);
        assert_eq!(knob("spp").unwrap().default_value(&common).unwrap(), "16");
    }

    #[test]
    fn values_set_what_the_knob_names() {
        let none = NamedSettings::new();
        let (k, v) = parse_knob_arg("sort_depth=4,all").unwrap();
        let sweep = k.sweep(v.as_deref(), &none).unwrap();
        let orders: Vec<String> = sweep
            .iter()
            .map(|v| v.spec.resolve(&none).unwrap().shadow_order.to_string())
            .collect();
        assert_eq!(
            orders,
            [
                "sorted:logging=sato:p=1:depth=4:budget=0.05",
                "sorted:logging=sato:p=1:budget=0.05"
            ]
        );
        assert!(sweep[1].is_default && !sweep[0].is_default);
        let (k, v) = parse_knob_arg("visibility=prepass:16x16").unwrap();
        let sweep = k.sweep(v.as_deref(), &none).unwrap();
        assert_eq!(sweep[0].spec.label, "prepass-16x16");
        assert_eq!(sweep[1].value, "previous");
        let (k, v) = parse_knob_arg("resolution=50").unwrap();
        assert_eq!(k.sweep(v.as_deref(), &none).unwrap()[0].percentage, 50);
    }

    #[test]
    fn docs_trade_md_holds_the_knob_table() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/trade.md");
        let text = std::fs::read_to_string(&path).unwrap_or_default();
        let (start, end) = ("<!-- knobs -->\n", "<!-- /knobs -->");
        let (Some(a), Some(b)) = (text.find(start), text.find(end)) else {
            panic!("docs/trade.md has no {start:?} ... {end:?} markers");
        };
        let table = knobs_markdown();
        if std::env::var_os("UPDATE_DOCS").is_some() {
            let new = format!("{}{start}{table}{}", &text[..a], &text[b..]);
            std::fs::write(&path, new).unwrap();
        } else {
            assert!(
                text[a + start.len()..b] == table,
                "docs/trade.md's knob table differs: run UPDATE_DOCS=1 cargo test -p antumbra-core --lib trade"
            );
        }
    }

    #[test]
    fn bad_knobs_and_values_are_named() {
        let e = parse_knob_arg("osah_x").unwrap_err().to_string();
        assert!(
            e.contains("'osah_x' is not a knob") && e.contains("osah_w, spatial_splits"),
            "{e}"
        );
        let (k, v) = parse_knob_arg("osah_w=2").unwrap();
        let e = k
            .sweep(v.as_deref(), &NamedSettings::new())
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("knob 'osah_w': value '2': osah_w:"), "{e}");
        let (k, v) = parse_knob_arg("resolution=0").unwrap();
        assert!(k.sweep(v.as_deref(), &NamedSettings::new()).is_err());
    }

    #[test]
    fn empty_values_are_refused_naming_the_knob_and_the_place() {
        // Issue 33: `spp=1,,,...` (a megabyte of commas) was read as `spp=1`.
        let commas = format!("spp=1{}", ",".repeat(1 << 20));
        let e = parse_knob_arg(&commas).unwrap_err().to_string();
        assert!(
            e.starts_with("knob 'spp': value 2 of "),
            "{}",
            &e[..e.len().min(200)]
        );
        assert!(e.contains("is empty"), "{}", &e[..e.len().min(200)]);
        // The message names the place, not the whole text.
        assert!(e.len() < 200, "{} bytes", e.len());
        for bad in ["spp=1,,4", "spp=,4", "spp=4,", "spp= , 4"] {
            let e = parse_knob_arg(bad).unwrap_err().to_string();
            assert!(
                e.starts_with("knob 'spp': value ") && e.contains("is empty"),
                "{bad}: {e}"
            );
        }
        assert!(parse_knob_arg("spp=1, 4").is_ok());
    }
}
