//! The render settings' one described schema: each setting's name, type, valid range, group and
//! one-line help, with its default read from [`RenderSettings::default`]. The CLI flags, the
//! protocol's named settings map, the Python client's keyword arguments and the Blender panel all
//! derive from [`SCHEMA`], so a setting is added here (and in the struct it sets) and nowhere else.

mod table;
mod value;

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::render::RenderSettings;
use crate::{Error, Result};

pub use table::SCHEMA;
pub use value::SettingValue;

/// What values a setting takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    Bool,
    /// An integer in `min..=max`.
    Int {
        min: i64,
        max: i64,
    },
    /// One of a few integers.
    IntChoice(&'static [i64]),
    /// A finite number in the range; `open` excludes the bounds (`(0, 1)`).
    Float {
        min: f64,
        max: f64,
        open: bool,
    },
    /// One of a few words.
    Choice(&'static [&'static str]),
    /// Text in a syntax of its own (checked by the setting's parser): `syntax` shows it.
    Text {
        syntax: &'static str,
    },
}

/// The panel section (and help heading) a setting belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Group {
    Sampling,
    Build,
    Osah,
    SpatialSplits,
    WideBvh,
    ShadowOrder,
}

impl Group {
    pub fn title(self) -> &'static str {
        match self {
            Group::Sampling => "Sampling",
            Group::Build => "Build",
            Group::Osah => "OSAH",
            Group::SpatialSplits => "Spatial splits",
            Group::WideBvh => "Wide BVH",
            Group::ShadowOrder => "Shadow order",
        }
    }
}

/// One setting: how it is named, checked and shown, and where it lives in [`RenderSettings`].
pub struct Setting {
    /// The name everywhere: CLI `--leaf-size` (underscores become dashes), protocol and Python
    /// `leaf_size`, the panel's property.
    pub name: &'static str,
    pub kind: Kind,
    pub group: Group,
    pub help: &'static str,
    /// The setting's value in `s`.
    pub get: fn(&RenderSettings) -> SettingValue,
    /// Stores `v`, already checked against `kind`; parsers of `Text` settings may still refuse.
    pub set: fn(&mut RenderSettings, &SettingValue) -> Result<()>,
}

impl Setting {
    /// The default value, read from `RenderSettings::default()`.
    pub fn default_value(&self) -> SettingValue {
        (self.get)(&RenderSettings::default())
    }

    /// `v` in this setting's type (an integer where a number is wanted becomes that number), or
    /// an error naming the setting, the expected type and what came.
    pub fn check(&self, v: &SettingValue) -> Result<SettingValue> {
        let wrong = || {
            Error::invalid(
                self.name,
                format!("expected {}, got {}", self.expected(), v.describe()),
            )
        };
        let out = match (self.kind, v) {
            (Kind::Bool, SettingValue::Bool(_)) => v.clone(),
            (Kind::Int { min, max }, SettingValue::Int(i)) if (min..=max).contains(i) => v.clone(),
            (Kind::IntChoice(list), SettingValue::Int(i)) if list.contains(i) => v.clone(),
            (Kind::Float { .. }, SettingValue::Int(i)) => {
                return self.check(&SettingValue::Float(*i as f64))
            }
            (Kind::Float { min, max, open }, SettingValue::Float(f)) => {
                let inside = if open {
                    *f > min && *f < max
                } else {
                    (min..=max).contains(f)
                };
                if !(f.is_finite() && inside) {
                    return Err(wrong());
                }
                v.clone()
            }
            (Kind::Choice(words), SettingValue::Text(t)) if words.contains(&t.as_str()) => {
                v.clone()
            }
            (Kind::Text { .. }, SettingValue::Text(_)) => v.clone(),
            _ => return Err(wrong()),
        };
        Ok(out)
    }

    /// What the setting accepts, as a user reads it: "an integer in 1..=64".
    pub fn expected(&self) -> String {
        match self.kind {
            Kind::Bool => "true or false".into(),
            Kind::Int { min, max } => format!("an integer in {min}..={max}"),
            Kind::IntChoice(list) => format!("one of {}", join(list.iter())),
            Kind::Float { min, max, open } => {
                let (l, r) = if open { ('(', ')') } else { ('[', ']') };
                format!("a number in {l}{min}, {max}{r}")
            }
            Kind::Choice(words) => format!("one of {}", join(words.iter())),
            Kind::Text { syntax } => format!("text: {syntax}"),
        }
    }

    /// Parses a command-line word into this setting's type (then checks it).
    pub fn parse(&self, text: &str) -> Result<SettingValue> {
        let bad = || {
            Error::invalid(
                self.name,
                format!("expected {}, got '{text}'", self.expected()),
            )
        };
        let v = match self.kind {
            Kind::Bool => SettingValue::Bool(match text {
                "true" | "on" | "yes" | "1" => true,
                "false" | "off" | "no" | "0" => false,
                _ => return Err(bad()),
            }),
            Kind::Int { .. } | Kind::IntChoice(_) => {
                SettingValue::Int(text.trim().parse().map_err(|_| bad())?)
            }
            Kind::Float { .. } => SettingValue::Float(text.trim().parse().map_err(|_| bad())?),
            Kind::Choice(_) | Kind::Text { .. } => SettingValue::Text(text.to_string()),
        };
        let v = self.check(&v)?;
        // Text is checked by its own parser, which the setter runs.
        (self.set)(&mut RenderSettings::default(), &v)?;
        Ok(v)
    }
}

fn join<T: std::fmt::Display>(items: impl Iterator<Item = T>) -> String {
    items.map(|i| i.to_string()).collect::<Vec<_>>().join(", ")
}

/// The schema as a Markdown table per group (docs/settings.md is this text, checked by a test).
pub fn markdown() -> String {
    let mut out = String::from(
        "# Render settings\n\nGenerated from `antumbra_core::settings::SCHEMA` (a test checks that \
         this file equals it; `UPDATE_DOCS=1 cargo test -p antumbra-core --lib settings` \
         rewrites it). The same names everywhere: `antumbra render --leaf-size 4`, the \
         protocol's and a spool job's `settings` map (`{\"leaf_size\": 4}`), Python's \
         `render(..., leaf_size=4)`, the batch's `--leaf-size 4` and the add-on panel's \
         property. A setting left out takes its default.\n",
    );
    let mut group = None;
    for s in SCHEMA {
        if group != Some(s.group) {
            group = Some(s.group);
            out += &format!(
                "\n## {}\n\n| setting | takes | default | what it does |\n|---|---|---|---|\n",
                s.group.title()
            );
        }
        out += &format!(
            "| `{}` | {} | `{}` | {} |\n",
            s.name,
            s.expected().replace('|', "\\|"),
            s.default_value(),
            s.help.replace('|', "\\|")
        );
    }
    out
}

/// The setting called `name`.
pub fn setting(name: &str) -> Option<&'static Setting> {
    SCHEMA.iter().find(|s| s.name == name)
}

/// Settings by name, as the protocol, recordings, spool jobs and the Python client carry them:
/// a missing setting takes its default; an unknown name or a wrong type is an error naming it.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
#[serde(transparent)]
pub struct NamedSettings(pub BTreeMap<String, SettingValue>);

/// By hand so that a value of no setting type is refused naming its setting.
impl<'de> Deserialize<'de> for NamedSettings {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = NamedSettings;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a map of setting names to values")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                mut map: A,
            ) -> std::result::Result<NamedSettings, A::Error> {
                let mut out = BTreeMap::new();
                while let Some(name) = map.next_key::<String>()? {
                    let value = map
                        .next_value::<SettingValue>()
                        .map_err(|e| serde::de::Error::custom(format!("setting '{name}': {e}")))?;
                    out.insert(name, value);
                }
                Ok(NamedSettings(out))
            }
        }
        d.deserialize_map(V)
    }
}

impl NamedSettings {
    pub fn new() -> Self {
        NamedSettings::default()
    }

    /// Adds `name = value` (builder style, for tests and examples).
    pub fn with(mut self, name: &str, value: impl Into<SettingValue>) -> Self {
        self.0.insert(name.to_string(), value.into());
        self
    }

    pub fn get(&self, name: &str) -> Option<&SettingValue> {
        self.0.get(name)
    }

    pub fn insert(&mut self, name: &str, value: impl Into<SettingValue>) {
        self.0.insert(name.to_string(), value.into());
    }

    /// The checked render settings these name, every other setting at its default.
    pub fn resolve(&self) -> Result<RenderSettings> {
        for name in self.0.keys() {
            if setting(name).is_none() {
                return Err(Error::invalid(
                    name.as_str(),
                    format!(
                        "unknown setting (known: {})",
                        join(SCHEMA.iter().map(|s| s.name))
                    ),
                ));
            }
        }
        let mut s = RenderSettings::default();
        // Schema order, not the map's: a setting that depends on another (build=srdh picks the
        // order) is listed after it.
        for spec in SCHEMA {
            if let Some(v) = self.0.get(spec.name) {
                let v = spec.check(v)?;
                (spec.set)(&mut s, &v)?;
            }
        }
        table::resolve_build_srdh(&mut s, self)?;
        s.validate()?;
        Ok(s)
    }
}

impl RenderSettings {
    /// Every setting by name (the inverse of [`NamedSettings::resolve`]).
    pub fn to_named(&self) -> NamedSettings {
        NamedSettings(
            SCHEMA
                .iter()
                .map(|spec| (spec.name.to_string(), (spec.get)(self)))
                .collect(),
        )
    }

    /// Checks every setting against its schema entry and the rules between settings.
    pub fn validate(&self) -> Result<()> {
        for spec in SCHEMA {
            spec.check(&(spec.get)(self))?;
        }
        table::check_relations(self)
    }
}

#[cfg(test)]
mod tests;
