//! A metric's value, or why it has none: what every metric module
//! returns, so that a report never shows NaN.

use serde::{Deserialize, Serialize};

/// A metric value, or why it has none.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Metric {
    /// The value; `None` when it cannot be defined.
    pub value: Option<f64>,
    /// True when the value is +infinity in the limit (a contrast over a zero
    /// reference with light present). `value` is then `None`.
    pub unbounded: bool,
    /// Why `value` is `None`, or a caveat.
    pub reason: Option<String>,
}

impl Metric {
    pub(super) fn value(v: f64) -> Self {
        debug_assert!(v.is_finite());
        Self {
            value: Some(v),
            unbounded: false,
            reason: None,
        }
    }

    pub(super) fn undefined(reason: String) -> Self {
        Self {
            value: None,
            unbounded: false,
            reason: Some(reason),
        }
    }
}
