//! A method of a comparison: a label and the settings it changes, written `LABEL=NAME=VALUE,...`
//! with the settings' own names, and the default set of methods every entry point offers.

use std::fmt;
use std::str::FromStr;

use crate::render::RenderSettings;
use crate::settings::{setting, NamedSettings};
use crate::{Error, Result};

/// One labelled method: the settings it names over the comparison's common ones.
#[derive(Clone, Debug, PartialEq)]
pub struct MethodSpec {
    pub label: String,
    pub settings: NamedSettings,
}

/// The comparison when none is given: the binary SAH tree front to back first (the baseline),
/// then the wide, per-light and visibility-driven methods antumbra is about, and `auto` (what a
/// render uses when told nothing). Each names its build, width and order, so none moves with
/// the defaults.
pub const DEFAULT_METHODS: &[&str] = &[
    "base=build=sah,width=2,order=fbto",
    "sato8=build=sah,width=8,order=sato",
    "sorted8=build=sah,width=8,order=sorted",
    "osah8=build=osah,visibility=previous,width=8,order=sorted",
    "srdh=build=sah,width=2,order=srdh",
    "auto8=build=auto,width=8,order=auto",
];

pub fn default_methods() -> Vec<MethodSpec> {
    DEFAULT_METHODS
        .iter()
        .map(|m| m.parse().expect("the default methods parse"))
        .collect()
}

fn invalid(spec: &str, message: impl Into<String>) -> Error {
    Error::invalid(format!("method '{spec}'"), message)
}

impl FromStr for MethodSpec {
    type Err = Error;

    /// `LABEL=NAME=VALUE,NAME=VALUE`; values may hold `:` and `=` (`order=sorted:depth=4`) but
    /// not `,`. The label is a word of letters, digits, `-`, `_` and `.` (it names files).
    fn from_str(spec: &str) -> Result<Self> {
        let (label, rest) = spec
            .split_once('=')
            .ok_or_else(|| invalid(spec, "expected LABEL=SETTINGS, e.g. base=build=sah,width=2"))?;
        let label = label.trim();
        check_label(spec, label)?;
        let mut settings = NamedSettings::new();
        for part in rest.split(',').map(str::trim).filter(|p| !p.is_empty()) {
            let (name, value) = part
                .split_once('=')
                .ok_or_else(|| invalid(spec, format!("'{part}' is not NAME=VALUE")))?;
            let name = name.trim();
            let s = setting(name).ok_or_else(|| {
                invalid(
                    spec,
                    format!("'{name}' is not a setting (see docs/settings.md)"),
                )
            })?;
            if settings.get(name).is_some() {
                return Err(invalid(spec, format!("'{name}' is given twice")));
            }
            settings.insert(name, s.parse(value.trim())?);
        }
        Ok(MethodSpec {
            label: label.to_string(),
            settings,
        })
    }
}

impl fmt::Display for MethodSpec {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        let parts: Vec<String> = self
            .settings
            .0
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect();
        write!(f, "{}={}", self.label, parts.join(","))
    }
}

/// The label is a word of letters, digits, `-`, `_` and `.` (it names files).
fn check_label(spec: &str, label: &str) -> Result<()> {
    let label_ok = !label.is_empty()
        && label.len() <= 64
        && label
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'));
    if label_ok {
        Ok(())
    } else {
        Err(invalid(
            spec,
            format!("the label '{label}' must be 1-64 letters, digits, '-', '_' or '.'"),
        ))
    }
}

impl MethodSpec {
    /// A method from a label and settings given apart (a client's map); the label is checked
    /// as in `LABEL=SETTINGS`, the settings when the method is resolved.
    pub fn new(label: &str, settings: NamedSettings) -> Result<Self> {
        check_label(label, label)?;
        Ok(MethodSpec {
            label: label.to_string(),
            settings,
        })
    }

    /// The render settings of this method: `common` (the comparison's shared settings, such as
    /// spp and seed), overridden by the method's own.
    pub fn resolve(&self, common: &NamedSettings) -> Result<RenderSettings> {
        let mut all = common.clone();
        for (k, v) in &self.settings.0 {
            all.insert(k, v.clone());
        }
        all.resolve()
            .map_err(|e| invalid(&self.to_string(), e.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_parse_and_resolve_to_distinct_methods() {
        let methods = default_methods();
        assert_eq!(methods[0].label, "base");
        let names: std::collections::BTreeSet<String> = methods
            .iter()
            .map(|m| m.resolve(&NamedSettings::new()).unwrap().method_name())
            .collect();
        assert_eq!(names.len(), methods.len(), "{names:?}");
    }

    #[test]
    fn values_keep_colons_and_equals() {
        let m: MethodSpec = "s4=order=sorted:depth=4:budget=0.5,width=4"
            .parse()
            .unwrap();
        let s = m.resolve(&NamedSettings::new()).unwrap();
        assert_eq!(s.width.get(), 4);
        assert_eq!(
            s.shadow_order.to_string(),
            "sorted:logging=sato:p=1:depth=4:budget=0.5"
        );
        assert_eq!(m.to_string().parse::<MethodSpec>().unwrap(), m);
    }

    #[test]
    fn bad_specs_name_what_is_wrong() {
        let err = |s: &str| s.parse::<MethodSpec>().unwrap_err().to_string();
        assert!(err("nolabel").contains("LABEL=SETTINGS"));
        assert!(err("a b=width=2").contains("label"));
        assert!(err("x=widht=2").contains("'widht' is not a setting"));
        assert!(err("x=width=3").contains("width"));
        assert!(err("x=width=2,width=4").contains("twice"));
        assert!(err("x=width").contains("not NAME=VALUE"));
    }
}
