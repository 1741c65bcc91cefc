//! Per-frame statistics: one row per frame, method and light (or the primary pass), with the
//! columns defined once here and written as CSV and JSON.
