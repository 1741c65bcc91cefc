//! Embree oracle.
