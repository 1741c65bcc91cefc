//! A setting's value as it travels: the four types JSON, MessagePack and Python share.

use serde::de::{self, Visitor};
use serde::{Deserialize, Deserializer, Serialize};

#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum SettingValue {
    Bool(bool),
    Int(i64),
    Float(f64),
    Text(String),
}

impl SettingValue {
    /// The value for an error message: its type and the value itself.
    pub fn describe(&self) -> String {
        match self {
            SettingValue::Bool(b) => format!("a boolean ({b})"),
            SettingValue::Int(i) => format!("an integer ({i})"),
            SettingValue::Float(f) => format!("a number ({f})"),
            SettingValue::Text(t) => format!("text ('{t}')"),
        }
    }

    pub fn as_bool(&self) -> bool {
        matches!(self, SettingValue::Bool(true))
    }

    /// The integer of a checked integer setting.
    pub fn as_int(&self) -> i64 {
        match self {
            SettingValue::Int(i) => *i,
            _ => 0,
        }
    }

    /// The number of a checked number setting.
    pub fn as_float(&self) -> f64 {
        match self {
            SettingValue::Float(f) => *f,
            SettingValue::Int(i) => *i as f64,
            _ => f64::NAN,
        }
    }

    pub fn as_text(&self) -> &str {
        match self {
            SettingValue::Text(t) => t,
            _ => "",
        }
    }
}

impl std::fmt::Display for SettingValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SettingValue::Bool(b) => write!(f, "{b}"),
            SettingValue::Int(i) => write!(f, "{i}"),
            SettingValue::Float(x) => write!(f, "{x}"),
            SettingValue::Text(t) => f.write_str(t),
        }
    }
}

impl From<bool> for SettingValue {
    fn from(b: bool) -> Self {
        SettingValue::Bool(b)
    }
}

impl From<i64> for SettingValue {
    fn from(i: i64) -> Self {
        SettingValue::Int(i)
    }
}

impl From<i32> for SettingValue {
    fn from(i: i32) -> Self {
        SettingValue::Int(i.into())
    }
}

impl From<u32> for SettingValue {
    fn from(i: u32) -> Self {
        SettingValue::Int(i.into())
    }
}

impl From<usize> for SettingValue {
    fn from(i: usize) -> Self {
        SettingValue::Int(i64::try_from(i).unwrap_or(i64::MAX))
    }
}

impl From<f32> for SettingValue {
    fn from(f: f32) -> Self {
        // Through the shortest decimal, so 0.9f32 reads back as 0.9, not 0.899999976...
        SettingValue::Float(f.to_string().parse().unwrap_or(f as f64))
    }
}

impl From<f64> for SettingValue {
    fn from(f: f64) -> Self {
        SettingValue::Float(f)
    }
}

impl From<&str> for SettingValue {
    fn from(t: &str) -> Self {
        SettingValue::Text(t.to_string())
    }
}

impl From<String> for SettingValue {
    fn from(t: String) -> Self {
        SettingValue::Text(t)
    }
}

/// By hand rather than `untagged`, so a value of another type (a list, a map, nil) is refused with
/// what a setting may hold instead of "did not match any variant".
impl<'de> Deserialize<'de> for SettingValue {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = SettingValue;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a boolean, an integer, a number or text")
            }
            fn visit_bool<E>(self, b: bool) -> Result<SettingValue, E> {
                Ok(SettingValue::Bool(b))
            }
            fn visit_i64<E>(self, i: i64) -> Result<SettingValue, E> {
                Ok(SettingValue::Int(i))
            }
            fn visit_u64<E: de::Error>(self, u: u64) -> Result<SettingValue, E> {
                i64::try_from(u)
                    .map(SettingValue::Int)
                    .map_err(|_| E::custom(format!("integer {u} is too large")))
            }
            fn visit_f64<E>(self, f: f64) -> Result<SettingValue, E> {
                Ok(SettingValue::Float(f))
            }
            fn visit_str<E>(self, t: &str) -> Result<SettingValue, E> {
                Ok(SettingValue::Text(t.to_string()))
            }
            fn visit_string<E>(self, t: String) -> Result<SettingValue, E> {
                Ok(SettingValue::Text(t))
            }
        }
        d.deserialize_any(V)
    }
}
