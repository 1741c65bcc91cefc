//! A light's kind read from the wire with errors that name the kind, the field and what was
//! expected: an internally tagged enum buffers its fields before it knows the kind, so its
//! errors said only `lights[0].kind: invalid type: string "x", expected f64`.

use std::fmt;

use serde::de::{self, IgnoredAny, MapAccess, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer};

use crate::messages::{AreaShapeState, LightKindState};

/// Each kind's `type` and its fields, in the order the messages list them.
const KINDS: [(&str, &[&str]); 4] = [
    ("Point", &["radius"]),
    ("Sun", &["angle"]),
    ("Spot", &["radius", "spot_size", "spot_blend"]),
    ("Area", &["shape", "size_x", "size_y"]),
];

/// The area shapes by name.
const SHAPES: [(&str, AreaShapeState); 4] = [
    ("Square", AreaShapeState::Square),
    ("Rectangle", AreaShapeState::Rectangle),
    ("Disk", AreaShapeState::Disk),
    ("Ellipse", AreaShapeState::Ellipse),
];

/// Any value a field may hold, kept so that a wrong one can be named once the kind is known.
#[derive(Debug)]
enum Field {
    Number(f64),
    Text(String),
    /// What it was instead (`a boolean`, `nil`, ...).
    Other(&'static str),
}

impl fmt::Display for Field {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Field::Number(x) => write!(f, "the number {x}"),
            Field::Text(t) => write!(f, "the text {t:?}"),
            Field::Other(what) => f.write_str(what),
        }
    }
}

impl<'de> Deserialize<'de> for Field {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Field;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("any value")
            }
            fn visit_f64<E>(self, v: f64) -> Result<Field, E> {
                Ok(Field::Number(v))
            }
            fn visit_i64<E>(self, v: i64) -> Result<Field, E> {
                Ok(Field::Number(v as f64))
            }
            fn visit_u64<E>(self, v: u64) -> Result<Field, E> {
                Ok(Field::Number(v as f64))
            }
            fn visit_str<E>(self, v: &str) -> Result<Field, E> {
                Ok(Field::Text(v.to_string()))
            }
            fn visit_bool<E>(self, _: bool) -> Result<Field, E> {
                Ok(Field::Other("a boolean"))
            }
            fn visit_unit<E>(self) -> Result<Field, E> {
                Ok(Field::Other("nil"))
            }
            fn visit_none<E>(self) -> Result<Field, E> {
                Ok(Field::Other("nil"))
            }
            fn visit_bytes<E>(self, _: &[u8]) -> Result<Field, E> {
                Ok(Field::Other("bytes"))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Field, A::Error> {
                while seq.next_element::<IgnoredAny>()?.is_some() {}
                Ok(Field::Other("an array"))
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Field, A::Error> {
                while map.next_entry::<IgnoredAny, IgnoredAny>()?.is_some() {}
                Ok(Field::Other("a map"))
            }
        }
        d.deserialize_any(V)
    }
}

/// The kind as it arrives: every field any kind has (others are ignored, as before).
#[derive(Deserialize)]
struct Wire {
    #[serde(rename = "type")]
    kind: Option<Field>,
    radius: Option<Field>,
    angle: Option<Field>,
    spot_size: Option<Field>,
    spot_blend: Option<Field>,
    shape: Option<Field>,
    size_x: Option<Field>,
    size_y: Option<Field>,
}

fn names<T>(list: &[(&str, T)]) -> String {
    list.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
}

impl Wire {
    fn kind(&self) -> Result<&'static str, String> {
        let expected = || format!("`type` must be one of {}", names(&KINDS));
        match &self.kind {
            Some(Field::Text(t)) => KINDS
                .iter()
                .find(|(n, _)| n == t)
                .map(|(n, _)| *n)
                .ok_or_else(|| format!("unknown light kind {t:?}: {}", expected())),
            Some(other) => Err(format!("{}, got {other}", expected())),
            None => Err(format!("no `type`: {}", expected())),
        }
    }

    fn field(&self, name: &str) -> Option<&Field> {
        match name {
            "radius" => self.radius.as_ref(),
            "angle" => self.angle.as_ref(),
            "spot_size" => self.spot_size.as_ref(),
            "spot_blend" => self.spot_blend.as_ref(),
            "shape" => self.shape.as_ref(),
            "size_x" => self.size_x.as_ref(),
            "size_y" => self.size_y.as_ref(),
            _ => None,
        }
    }
}

impl<'de> Deserialize<'de> for LightKindState {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let wire = Wire::deserialize(d)?;
        let kind = wire.kind().map_err(de::Error::custom)?;
        let fields = KINDS
            .iter()
            .find(|(n, _)| *n == kind)
            .map_or(&[][..], |k| k.1);
        let get = |name: &str| -> Result<&Field, D::Error> {
            wire.field(name).ok_or_else(|| {
                de::Error::custom(format!(
                    "a {kind} light needs `{name}` (its fields: {})",
                    fields.join(", ")
                ))
            })
        };
        let number = |name: &str| -> Result<f64, D::Error> {
            match get(name)? {
                Field::Number(x) => Ok(*x),
                other => Err(de::Error::custom(format!(
                    "{kind}.{name}: expected a number (f64), got {other}"
                ))),
            }
        };
        Ok(match kind {
            "Point" => LightKindState::Point {
                radius: number("radius")?,
            },
            "Sun" => LightKindState::Sun {
                angle: number("angle")?,
            },
            "Spot" => LightKindState::Spot {
                radius: number("radius")?,
                spot_size: number("spot_size")?,
                spot_blend: number("spot_blend")?,
            },
            _ => {
                let shape = get("shape")?;
                let found = match shape {
                    Field::Text(t) => SHAPES.iter().find(|(n, _)| n == t).map(|s| s.1),
                    _ => None,
                };
                LightKindState::Area {
                    shape: found.ok_or_else(|| {
                        de::Error::custom(format!(
                            "Area.shape: expected one of {}, got {shape}",
                            names(&SHAPES)
                        ))
                    })?,
                    size_x: number("size_x")?,
                    size_y: number("size_y")?,
                }
            }
        })
    }
}
