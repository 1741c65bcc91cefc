//! The child order of shadow (occlusion) rays as a run setting, with the command-line syntax
//! `stored | fbto | sato | rtsah | random[:seed=S] | sorted[:logging=sato|fbto][:p=1|area][:depth=K][:budget=F]
//! | srdh[:rays=WxH|all|F][:bins=B][:leaf=K][:kernels=all|constant|directional][:min_occluded=F] | auto`
//! (`near` is accepted for `fbto`, its older name).

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use super::child_sort::{ChildHitModel, LoggingOrder, SortSettings};
use super::srdh_settings::SrdhSettings;
use crate::{Error, Result};

/// The order in which the two children of a binary node are visited by an occlusion query
/// (the binary traversal's run setting; [`super::Stored`] and [`super::FrontToBack`] as types).
/// The answer never depends on it; only the work does.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum AnyHitOrder {
    /// Left child first, as the builder stored it.
    Stored,
    /// The child whose box the ray enters first (front to back).
    #[default]
    NearFirst,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum ShadowOrder {
    /// Children in the order the builder (and the collapse) stored them.
    Stored,
    /// Front to back by box entry distance (`NearFirst` in older settings).
    #[default]
    #[serde(alias = "NearFirst")]
    Fbto,
    /// Largest child box first.
    Sato,
    /// By estimated termination probability over cost, from geometry alone.
    Rtsah,
    /// A seeded random order per node.
    Random { seed: u32 },
    /// Per light, sorted from representative shadow rays.
    Sorted(SortSettings),
    /// Per light, a binary SRDH tree with traversal kernels built from representative rays
    /// (lights with few occluded rays trace the binary tree front to back).
    Srdh(SrdhSettings),
}

impl ShadowOrder {
    /// Whether the order is made from the tree alone (SATO, RTSAH, random): the same for every
    /// light and every frame that reuses the tree, so it is prepared once per tree.
    pub fn is_per_tree(&self) -> bool {
        matches!(
            self,
            ShadowOrder::Sato | ShadowOrder::Rtsah | ShadowOrder::Random { .. }
        )
    }

    /// The binary traversal's order when this order is one it has (stored or front to back).
    pub fn binary(&self) -> Option<AnyHitOrder> {
        match self {
            ShadowOrder::Stored => Some(AnyHitOrder::Stored),
            ShadowOrder::Fbto => Some(AnyHitOrder::NearFirst),
            _ => None,
        }
    }
}

impl From<AnyHitOrder> for ShadowOrder {
    fn from(o: AnyHitOrder) -> Self {
        match o {
            AnyHitOrder::Stored => ShadowOrder::Stored,
            AnyHitOrder::NearFirst => ShadowOrder::Fbto,
        }
    }
}

fn invalid(msg: String) -> Error {
    Error::invalid("order", msg)
}

const KNOWN: &str = "stored, fbto, sato, rtsah, random[:seed=S], \
                     sorted[:logging=sato|fbto][:p=1|area][:depth=K][:budget=F], \
                     srdh[:rays=WxH|all|F][:bins=B][:leaf=K][:kernels=all|constant|directional][:min_occluded=F], \
                     auto";

impl FromStr for ShadowOrder {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        let mut parts = s.trim().split(':');
        let name = parts.next().unwrap_or_default();
        let options: Vec<(&str, &str)> = parts
            .map(|p| {
                p.split_once('=')
                    .ok_or_else(|| invalid(format!("'{p}' in '{s}' is not key=value")))
            })
            .collect::<Result<_>>()?;
        let no_options = |order: ShadowOrder| match options.first() {
            None => Ok(order),
            Some((k, _)) => Err(invalid(format!("'{name}' takes no option '{k}'"))),
        };
        match name {
            "stored" => no_options(ShadowOrder::Stored),
            "fbto" | "near" => no_options(ShadowOrder::Fbto),
            "sato" => no_options(ShadowOrder::Sato),
            // `auto` is a policy (`render::Pick`), which reads the bare word before this parser.
            "auto" => Err(match options.first() {
                Some((k, _)) => invalid(format!("'auto' takes no option '{k}'")),
                None => invalid("'auto' chooses an order per light; it is not one".into()),
            }),
            "rtsah" => no_options(ShadowOrder::Rtsah),
            "random" => {
                let mut seed = 0;
                for (k, v) in options {
                    match k {
                        "seed" => {
                            seed = v
                                .parse()
                                .map_err(|_| invalid(format!("random: bad seed '{v}'")))?
                        }
                        _ => return Err(invalid(format!("random: unknown option '{k}'"))),
                    }
                }
                Ok(ShadowOrder::Random { seed })
            }
            "sorted" => {
                let mut st = SortSettings::default();
                for (k, v) in options {
                    match (k, v) {
                        ("logging", "sato") => st.logging = LoggingOrder::Sato,
                        ("logging", "fbto") => st.logging = LoggingOrder::Fbto,
                        ("p", "1") => st.p = ChildHitModel::One,
                        ("p", "area") => st.p = ChildHitModel::Area,
                        ("depth", d) => {
                            st.depth = Some(d.parse().map_err(|_| {
                                invalid(format!("sorted: depth must be an integer, got '{d}'"))
                            })?)
                        }
                        ("budget", f) => st.budget = parse_budget(f)?,
                        _ => {
                            return Err(invalid(format!(
                                "sorted: unknown option '{k}={v}' (known: logging=sato|fbto, p=1|area, depth=K, budget=F)"
                            )))
                        }
                    }
                }
                let order = ShadowOrder::Sorted(st);
                order.validate()?;
                Ok(order)
            }
            "srdh" => Ok(ShadowOrder::Srdh(SrdhSettings::parse_options(&options)?)),
            other => Err(invalid(format!("unknown order '{other}' (known: {KNOWN})"))),
        }
    }
}

/// A share of the rays: "0.05" or "5%", in (0, 1].
fn parse_budget(f: &str) -> Result<f32> {
    let v = match f.strip_suffix('%') {
        Some(p) => p.parse::<f32>().map(|p| p / 100.0),
        None => f.parse::<f32>(),
    }
    .map_err(|_| invalid(format!("sorted: budget must be a number, got '{f}'")))?;
    if !(v > 0.0 && v <= 1.0) {
        return Err(invalid(format!(
            "sorted: budget must be in (0, 1], got {f}"
        )));
    }
    Ok(v)
}

impl fmt::Display for ShadowOrder {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ShadowOrder::Stored => write!(f, "stored"),
            ShadowOrder::Fbto => write!(f, "fbto"),
            ShadowOrder::Sato => write!(f, "sato"),
            ShadowOrder::Rtsah => write!(f, "rtsah"),
            ShadowOrder::Random { seed } => write!(f, "random:seed={seed}"),
            ShadowOrder::Sorted(s) => {
                let logging = match s.logging {
                    LoggingOrder::Sato => "sato",
                    LoggingOrder::Fbto => "fbto",
                };
                let p = match s.p {
                    ChildHitModel::One => "1",
                    ChildHitModel::Area => "area",
                };
                write!(f, "sorted:logging={logging}:p={p}")?;
                if let Some(d) = s.depth {
                    write!(f, ":depth={d}")?;
                }
                write!(f, ":budget={}", s.budget)
            }
            ShadowOrder::Srdh(s) => write!(f, "{s}"),
        }
    }
}

impl ShadowOrder {
    /// Checks the values a parsed order cannot have wrong but a deserialised one can.
    pub fn validate(&self) -> Result<()> {
        match self {
            ShadowOrder::Sorted(s) if !(s.budget > 0.0 && s.budget <= 1.0) => Err(invalid(
                format!("sorted: budget must be in (0, 1], got {}", s.budget),
            )),
            // The root is depth 0: a limit of 0 would sort no node at all.
            ShadowOrder::Sorted(s) if s.depth == Some(0) => Err(invalid(
                "sorted: depth must be at least 1 (the root is depth 0), got 0".into(),
            )),
            ShadowOrder::Srdh(s) => s.validate(),
            _ => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_order_round_trips_through_its_text() {
        for text in [
            "stored",
            "fbto",
            "sato",
            "rtsah",
            "random:seed=7",
            "sorted:logging=fbto:p=area:depth=4:budget=0.01",
            "sorted:logging=sato:p=1:budget=0.05",
            "srdh:rays=16x16:bins=32:leaf=1:kernels=all:min_occluded=0.2",
            "srdh:rays=all:bins=8:leaf=4:kernels=constant:min_occluded=0",
            "srdh:rays=0.05:bins=32:leaf=1:kernels=directional:min_occluded=0.5",
        ] {
            let o: ShadowOrder = text.parse().unwrap();
            assert_eq!(o.to_string(), text);
            assert_eq!(o.to_string().parse::<ShadowOrder>().unwrap(), o);
        }
    }

    #[test]
    fn options_and_aliases() {
        assert_eq!("near".parse::<ShadowOrder>().unwrap(), ShadowOrder::Fbto);
        let ShadowOrder::Sorted(s) = "sorted:budget=10%:depth=3".parse().unwrap() else {
            panic!("not sorted")
        };
        assert_eq!((s.budget, s.depth), (0.1, Some(3)));
        assert_eq!(s.logging, LoggingOrder::Sato);
        let ShadowOrder::Srdh(s) = "srdh".parse().unwrap() else {
            panic!("not srdh")
        };
        assert_eq!(s, SrdhSettings::default());
        for bad in [
            "sorted:budget=0",
            "sorted:budget=2",
            "sorted:p=2",
            "sorted:depth=x",
            "sorted:depth=0",
            "sato:depth=3",
            "sorted:logging",
            "front",
            "srdh:bins=1",
            "srdh:leaf=0",
            "srdh:rays=0x4",
            "srdh:rays=2",
            "srdh:kernels=some",
            "srdh:min_occluded=1.5",
            "srdh:depth=3",
            "auto:xyz",
            "auto:budget=0.1",
        ] {
            assert!(bad.parse::<ShadowOrder>().is_err(), "{bad}");
        }
    }
}
