//! Repeated runs of one test on one device and firmware: each run's KPI
//! values, and the run-to-run spread `compare` measures from them
//! (docs/campaigns.md, "Where sigma comes from: repeated runs").

use std::collections::BTreeMap;

/// A KPI: (case id, ROI, metric).
pub type Key = (String, String, String);

/// Repeated runs of A's and B's test on their devices: each run's KPI
/// values, by group (0: runs like A, 1: runs like B; one group when A and
/// B are of the same device and firmware).
#[derive(Debug, Clone, Default)]
pub struct Repeats {
    /// (group, run id, KPI -> value) of every run in the groups, A and B
    /// left out.
    pub runs: Vec<(usize, i64, BTreeMap<Key, f64>)>,
    /// A and B are of one device and firmware: one group.
    pub one_group: bool,
}

impl Repeats {
    /// Runs in group `g`.
    pub fn count(&self, g: usize) -> usize {
        self.runs.iter().filter(|(h, _, _)| *h == g).count()
    }

    /// The pooled within-group standard deviation of `f` over the runs
    /// where it is defined, with its degrees of freedom `sum(n_g - 1)` and
    /// the runs' residuals from their group's mean in units of it; `None`
    /// without a group of two such runs.
    pub(super) fn spread(&self, f: impl Fn(&BTreeMap<Key, f64>) -> Option<f64>) -> Option<Spread> {
        let mut groups: BTreeMap<usize, Vec<f64>> = BTreeMap::new();
        for (g, _, values) in &self.runs {
            if let Some(x) = f(values).filter(|x| x.is_finite()) {
                groups.entry(*g).or_default().push(x);
            }
        }
        let (mut ss, mut df, mut residuals) = (0.0, 0usize, Vec::new());
        for xs in groups.values().filter(|xs| xs.len() >= 2) {
            df += xs.len() - 1;
            // Equal values spread by exactly 0: their computed mean may
            // differ from them in the last bit, and a noiseless KPI would
            // get a sigma of 1e-15 and a change of 1e13 sigma.
            if xs.iter().all(|x| x.to_bits() == xs[0].to_bits()) {
                residuals.extend(xs.iter().map(|_| 0.0));
                continue;
            }
            let mean = xs.iter().sum::<f64>() / xs.len() as f64;
            ss += xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>();
            residuals.extend(xs.iter().map(|x| x - mean));
        }
        if df == 0 {
            return None;
        }
        let sd = (ss / df as f64).max(0.0).sqrt();
        if sd > 0.0 {
            residuals.iter_mut().for_each(|r| *r /= sd);
        }
        Some(Spread { sd, df, residuals })
    }
}

/// A spread measured over repeated runs.
#[derive(Debug, Clone)]
pub(super) struct Spread {
    /// Pooled within-group standard deviation.
    pub(super) sd: f64,
    /// Its degrees of freedom.
    pub(super) df: usize,
    /// Each run's residual from its group's mean, in units of `sd`.
    pub(super) residuals: Vec<f64>,
}

/// Excess kurtosis of residuals (0 for a normal distribution), at least
/// 0; 0 with fewer than 4.
pub(super) fn excess_kurtosis(residuals: &[f64]) -> f64 {
    if residuals.len() < 4 {
        return 0.0;
    }
    let n = residuals.len() as f64;
    let m2 = residuals.iter().map(|r| r * r).sum::<f64>() / n;
    let m4 = residuals.iter().map(|r| r.powi(4)).sum::<f64>() / n;
    if m2 > 0.0 {
        (m4 / (m2 * m2) - 3.0).max(0.0)
    } else {
        0.0
    }
}

/// The degrees of freedom of Student's t that match the uncertainty of a
/// variance estimated from `runs` runs with `df` degrees of freedom when
/// the values have excess kurtosis `excess`: `Var(s^2) / sigma^4 =
/// 2 / df + excess / runs` (2 / df for normal values), so `2 / (2 / df +
/// excess / runs)`. Heavy tails make the estimate less certain, and the
/// gate wider.
pub(super) fn effective_df(df: usize, runs: usize, excess: f64) -> usize {
    let v = 2.0 / (2.0 / df as f64 + excess / runs.max(1) as f64);
    (v.floor() as usize).clamp(1, df)
}
