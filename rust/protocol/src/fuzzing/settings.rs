//! The `settings` target: arbitrary bytes as a settings map (a spool job's JSON, the wire's
//! MessagePack) and as command-line flags and values, through every settings parser.

use std::fmt::{Debug, Display};
use std::str::FromStr;

use antumbra_core::build::{BuildMethod, CollapseMethod, SpatialAxes};
use antumbra_core::bvh::BvhWidth;
use antumbra_core::order::ShadowOrder;
use antumbra_core::render::VisibilitySource;
use antumbra_core::scene::ImageSize;
use antumbra_core::settings::{setting, NamedSettings};

use crate::convert::render_settings;
use crate::frame::decode_body;

/// Decodes `data` as a JSON and as a MessagePack settings map, and reads it as lines of flags
/// (`--order sorted:depth=0`) and of bare values given to every text parser. Every map either
/// resolves to settings that validate and round-trip through their names, or is refused with an
/// error naming one of its settings; every parsed value prints back to itself. Never panics.
pub fn settings(data: &[u8]) {
    if let Ok(named) = serde_json::from_slice::<NamedSettings>(data) {
        check_map(&named);
    }
    if let Ok(named) = decode_body::<NamedSettings>(data) {
        check_map(&named);
    }
    let text = String::from_utf8_lossy(data);
    let mut flags = NamedSettings::new();
    for line in text.lines() {
        match line.split_once(' ') {
            Some((flag, value)) if flag.starts_with("--") => {
                let name = flag.trim_start_matches('-').replace('-', "_");
                if let Some(spec) = setting(&name) {
                    match spec.parse(value) {
                        Ok(v) => flags.insert(&name, v),
                        Err(e) => assert_names(&e, &name),
                    }
                }
            }
            _ => values(line),
        }
    }
    check_map(&flags);
}

/// The settings a map resolves to, or its error naming a given setting.
fn check_map(named: &NamedSettings) {
    match render_settings(named) {
        Ok(s) => {
            if let Err(e) = s.validate() {
                panic!("{named:?} resolved to settings that do not validate: {e}");
            }
            let again = s.to_named().resolve();
            assert_eq!(again.as_ref().ok(), Some(&s), "{named:?}: {again:?}");
        }
        Err(e) => {
            let msg = e.to_string();
            assert!(
                named.0.keys().any(|k| msg.starts_with(&format!("{k}:"))),
                "{named:?}: the error names no given setting: {msg}"
            );
        }
    }
}

fn assert_names(e: &impl Display, field: &str) {
    let msg = e.to_string();
    assert!(
        msg.starts_with(&format!("{field}:")),
        "'{field}' refused without naming it: {msg}"
    );
}

/// `text` through each setting's text parser on its own.
fn values(text: &str) {
    if let Some(order) = round_trip::<ShadowOrder>(text, Some("order")) {
        if let Err(e) = order.validate() {
            panic!("'{text}' parsed to an order that does not validate: {e}");
        }
    }
    if let Some(v) = round_trip::<VisibilitySource>(text, Some("visibility")) {
        if let Err(e) = v.validate() {
            panic!("'{text}' parsed to a visibility that does not validate: {e}");
        }
    }
    round_trip::<ImageSize>(text, None);
    round_trip::<BuildMethod>(text, Some("build"));
    round_trip::<CollapseMethod>(text, Some("collapse"));
    round_trip::<SpatialAxes>(text, None);
    round_trip::<BvhWidth>(text, Some("width"));
}

/// Parses `text` as a `T`: a value prints to text that parses back to it; a refusal names
/// `field` when it is a setting's own error.
fn round_trip<T>(text: &str, field: Option<&str>) -> Option<T>
where
    T: FromStr + Printed + PartialEq + Debug,
    T::Err: Display,
{
    match text.parse::<T>() {
        Ok(v) => {
            let printed = v.printed();
            match printed.parse::<T>() {
                Ok(again) => assert_eq!(again, v, "'{text}' printed as '{printed}'"),
                Err(e) => panic!("'{text}' printed as '{printed}', which is refused: {e}"),
            }
            Some(v)
        }
        Err(e) => {
            if let Some(field) = field {
                assert_names(&e, field);
            }
            None
        }
    }
}

/// How a parsed value is written back (`Display`, or the type's `name`).
trait Printed {
    fn printed(&self) -> String;
}

macro_rules! printed_by_display {
    ($($t:ty),*) => {$(
        impl Printed for $t {
            fn printed(&self) -> String {
                self.to_string()
            }
        }
    )*};
}

printed_by_display!(
    ShadowOrder,
    ImageSize,
    CollapseMethod,
    SpatialAxes,
    BvhWidth
);

impl Printed for VisibilitySource {
    fn printed(&self) -> String {
        self.name()
    }
}

impl Printed for BuildMethod {
    fn printed(&self) -> String {
        self.name().into()
    }
}
