//! [`Pick`]: a setting the renderer's policy may choose as the frames go (`auto`), or a fixed
//! value. The builders and orders below know nothing of `auto`: it is the policy's word.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::build::BuildMethod;
use crate::order::ShadowOrder;
use crate::Error;

/// `auto` (chosen per frame, or per light and frame, from measured work: docs/auto.md), or one
/// fixed value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Pick<T> {
    Auto,
    Fixed(T),
}

/// The word that names [`Pick::Auto`] in every setting that takes it.
pub const AUTO: &str = "auto";

impl<T> Pick<T> {
    /// The fixed value, or `None` for `auto`.
    pub fn fixed(&self) -> Option<&T> {
        match self {
            Pick::Auto => None,
            Pick::Fixed(t) => Some(t),
        }
    }

    pub fn is_auto(&self) -> bool {
        matches!(self, Pick::Auto)
    }
}

impl<T> From<T> for Pick<T> {
    fn from(t: T) -> Self {
        Pick::Fixed(t)
    }
}

impl Pick<BuildMethod> {
    /// Whether the build may read a visible-triangle set (`auto` may choose OSAH).
    pub fn uses_visibility(&self) -> bool {
        self.fixed().is_none_or(BuildMethod::uses_visibility)
    }
}

impl Pick<ShadowOrder> {
    /// Whether this order is, or `auto` may choose, a light's own SRDH tree.
    pub fn may_trace_srdh(&self) -> bool {
        self.fixed()
            .is_none_or(|o| matches!(o, ShadowOrder::Srdh(_)))
    }
}

impl<T: fmt::Display> fmt::Display for Pick<T> {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        match self {
            Pick::Auto => f.write_str(AUTO),
            Pick::Fixed(t) => t.fmt(f),
        }
    }
}

impl<T: FromStr<Err = Error>> FromStr for Pick<T> {
    type Err = Error;
    fn from_str(s: &str) -> crate::Result<Self> {
        match s.trim() {
            AUTO => Ok(Pick::Auto),
            other => other.parse().map(Pick::Fixed),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auto_and_fixed_values_round_trip_through_their_text() {
        for text in ["auto", "sah", "osah", "vsah"] {
            let p: Pick<BuildMethod> = text.parse().unwrap();
            assert_eq!(p.to_string(), text);
        }
        for text in ["auto", "fbto", "sorted:logging=sato:p=1:budget=0.05"] {
            let p: Pick<ShadowOrder> = text.parse().unwrap();
            assert_eq!(p.to_string(), text);
        }
        assert_eq!(
            " auto ".parse::<Pick<ShadowOrder>>().unwrap(),
            Pick::<ShadowOrder>::Auto
        );
    }

    #[test]
    fn auto_takes_no_options_and_is_neither_a_builder_nor_an_order() {
        for bad in ["auto:xyz", "auto:budget=0.1", "autox"] {
            let e = bad.parse::<Pick<ShadowOrder>>().unwrap_err().to_string();
            assert!(e.contains("order"), "{bad}: {e}");
        }
        assert!("auto".parse::<ShadowOrder>().is_err());
        assert!("auto".parse::<BuildMethod>().is_err());
        assert!("autox".parse::<Pick<BuildMethod>>().is_err());
    }

    #[test]
    fn auto_may_read_visibility_and_trace_srdh() {
        assert!(Pick::<BuildMethod>::Auto.uses_visibility());
        assert!(!Pick::Fixed(BuildMethod::Sah).uses_visibility());
        assert!(Pick::Fixed(BuildMethod::Osah).uses_visibility());
        assert!(Pick::<ShadowOrder>::Auto.may_trace_srdh());
        assert!(!Pick::Fixed(ShadowOrder::Sato).may_trace_srdh());
    }
}
