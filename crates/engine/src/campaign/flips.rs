//! Verdict flips between two runs and their causes: a changed limit, a
//! case judged in one run only, a regression, or the noise
//! (docs/campaigns.md, "Like with like").

use std::collections::{BTreeMap, BTreeSet};

use super::query::CaseData;

/// Why a case's verdict differs between the runs.
#[derive(Debug, Clone, PartialEq)]
pub enum FlipCause {
    /// A limit of the case differs between the plans (the words say
    /// which): the test changed, not necessarily the camera.
    LimitChanged(String),
    /// The case is judged in one run only (e.g. the mitigation range
    /// changed).
    JudgedInOneRun,
    /// A KPI of the case regressed.
    Regressed,
    /// The KPIs moved across the limit by less than the gate: within the
    /// noise or below the floor.
    WithinNoise,
}

impl FlipCause {
    /// The cause in words.
    pub fn describe(&self) -> String {
        match self {
            FlipCause::LimitChanged(what) => format!("the limit changed ({what}), not the camera"),
            FlipCause::JudgedInOneRun => "judged in one run only".to_string(),
            FlipCause::Regressed => "a KPI regressed".to_string(),
            FlipCause::WithinNoise => {
                "the change is within the noise or below the floor".to_string()
            }
        }
    }
}

/// A case whose verdict differs between the runs.
#[derive(Debug, Clone)]
pub struct Flip {
    /// Case id.
    pub case: String,
    /// Verdict in A and in B.
    pub from: String,
    /// See `from`.
    pub to: String,
    /// Why.
    pub cause: FlipCause,
}

/// The limits of a case that differ between A and B, in words; `None`
/// when they are the same.
pub(super) fn limit_change(a: &CaseData, b: &CaseData) -> Option<String> {
    let limits = |c: &CaseData| -> BTreeMap<(String, String), String> {
        c.checks
            .iter()
            .map(|x| {
                (
                    (x.roi.clone(), x.metric.clone()),
                    format!("{} {}", x.comparison, x.threshold),
                )
            })
            .collect()
    };
    let (la, lb) = (limits(a), limits(b));
    let keys: BTreeSet<&(String, String)> = la.keys().chain(lb.keys()).collect();
    let words: Vec<String> = keys
        .into_iter()
        .filter(|k| la.get(*k) != lb.get(*k))
        .map(|k| {
            let side = |l: &BTreeMap<(String, String), String>| {
                l.get(k).cloned().unwrap_or_else(|| "no limit".to_string())
            };
            format!("{} {}: {} -> {}", k.0, k.1, side(&la), side(&lb))
        })
        .collect();
    (!words.is_empty()).then(|| words.join("; "))
}
