//! What `auto` remembers across the frames of one Renderer: per light and per shadow order, and
//! per camera-tree build, the estimated cost per ray last measured and on which frame.

use std::collections::BTreeMap;

use super::cost::Traversal;
use crate::order::ShadowOrder;

/// A shadow order `auto` may pick for a light.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum OrderChoice {
    /// Front to back: no preparation at all.
    Fbto,
    /// SATO: made once per tree, shared by every light and frame that reuses the tree.
    Sato,
    /// Sorted per light from logged representative rays.
    Sorted,
    /// The light's own SRDH tree (front to back where too few rays are occluded).
    Srdh,
}

impl OrderChoice {
    pub const ALL: [OrderChoice; 4] = [
        OrderChoice::Fbto,
        OrderChoice::Sato,
        OrderChoice::Sorted,
        OrderChoice::Srdh,
    ];

    pub fn name(self) -> &'static str {
        match self {
            OrderChoice::Fbto => "fbto",
            OrderChoice::Sato => "sato",
            OrderChoice::Sorted => "sorted",
            OrderChoice::Srdh => "srdh",
        }
    }

    /// The order with its default options.
    pub fn order(self) -> ShadowOrder {
        match self {
            OrderChoice::Fbto => ShadowOrder::Fbto,
            OrderChoice::Sato => ShadowOrder::Sato,
            OrderChoice::Sorted => ShadowOrder::Sorted(Default::default()),
            OrderChoice::Srdh => ShadowOrder::Srdh(Default::default()),
        }
    }

    /// The traversal its rays run, on a wide tree or not (SRDH always traces a binary tree:
    /// the light's own, or the shared one front to back).
    pub fn kernel(self, wide: bool) -> Traversal {
        match self {
            OrderChoice::Srdh => Traversal::BinaryAnyHit,
            _ if !wide => Traversal::BinaryAnyHit,
            OrderChoice::Fbto => Traversal::WideFrontToBack,
            OrderChoice::Sato | OrderChoice::Sorted => Traversal::WideAnyHit,
        }
    }

    /// Whether the order prepares each light (logging and sorting, or an SRDH build).
    pub fn per_light(self) -> bool {
        matches!(self, OrderChoice::Sorted | OrderChoice::Srdh)
    }

    fn index(self) -> usize {
        self as usize
    }
}

/// How the camera tree of a frame is had.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BuildChoice {
    Sah,
    /// OSAH from the previous frame's visible set.
    Osah,
    /// Last frame's tree, unchanged (only when no geometry moved).
    Keep,
}

impl BuildChoice {
    pub fn name(self) -> &'static str {
        match self {
            BuildChoice::Sah => "sah",
            BuildChoice::Osah => "osah",
            BuildChoice::Keep => "keep",
        }
    }
}

/// One measurement: estimated ns per ray, and the renderer's frame count when it was taken.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measured {
    pub per_ray_ns: f64,
    pub frame: u64,
    /// SRDH only: whether the light got its own tree (else it traced front to back).
    pub built: bool,
}

/// Per light (by name), the last measurement of each order.
#[derive(Clone, Debug, Default)]
pub struct History {
    lights: BTreeMap<String, [Option<Measured>; 4]>,
    /// Primary rays' cost right after a fresh SAH and a fresh OSAH build.
    sah: Option<Measured>,
    osah: Option<Measured>,
    /// Primary rays' cost on the last frame, whatever its tree: what keeping that tree costs.
    last_primary: Option<Measured>,
}

impl History {
    pub fn order(&self, light: &str, order: OrderChoice) -> Option<Measured> {
        self.lights.get(light).and_then(|m| m[order.index()])
    }

    pub fn record_order(&mut self, light: &str, order: OrderChoice, m: Measured) {
        self.lights.entry(light.to_string()).or_default()[order.index()] = Some(m);
    }

    pub fn build(&self, build: BuildChoice) -> Option<Measured> {
        match build {
            BuildChoice::Sah => self.sah,
            BuildChoice::Osah => self.osah,
            BuildChoice::Keep => self.last_primary,
        }
    }

    /// The primary rays' cost on a frame whose camera tree was had by `build`.
    pub fn record_build(&mut self, build: BuildChoice, m: Measured) {
        match build {
            BuildChoice::Sah => self.sah = Some(m),
            BuildChoice::Osah => self.osah = Some(m),
            BuildChoice::Keep => {}
        }
        self.last_primary = Some(m);
    }
}
