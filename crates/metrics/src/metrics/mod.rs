//! Flicker metrics on per-frame ROI luma traces, and pass/fail verdicts.
//!
//! Sits after the backends: it sees only luma values and segment labels,
//! never the physics that made them, so simulated and captured traces are
//! measured the same way.

pub mod chromaticity;
pub mod flicker;
pub mod glossary;
pub mod metric;
pub mod p2020;
pub mod verdict;
pub mod visibility;

pub use flicker::{Levels, Metric, RoiMetrics, evaluate_roi};
pub use glossary::{GLOSSARY, MetricName, VISIBILITY_GLOSSARY, human_name, short_name};
pub use verdict::{Check, Verdict, evaluate_case};
