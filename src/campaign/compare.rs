//! Comparing two recorded runs: what differs between their set-ups, every
//! KPI's change per case and ROI, the verdict flips and their causes, and
//! the noise-aware regression gate (docs/campaigns.md, "The regression
//! gate").
//!
//! A KPI's change counts as a regression when it goes the way the KPI's
//! check calls worse, by more than its practical floor, and by more than
//! `k` standard deviations of the run-to-run difference, `k` chosen so
//! that the chance of any false alarm over all KPIs is at most `alpha / 2`
//! (Bonferroni). The standard deviation is measured from repeated runs of
//! the same test on the same device when the database holds them (with
//! Student's t for the uncertainty of that estimate), else taken from the
//! runs' traces, inflated by the ratio measured between the two. A change
//! too small to show in one case but shared by many is caught by a pooled
//! score per metric, with the other half of `alpha`, by a procedure that
//! holds when the cases are correlated.

use std::collections::{BTreeMap, BTreeSet};

use super::query::{CaseData, RoiData, RunData, RunRow};
use super::setup::{self, Difference, Kind};

/// Chance of a false alarm over a whole comparison, when nothing changed.
pub const ALPHA: f64 = 0.05;

/// Share of `alpha` the gates spend: the KPIs' run-to-run values have
/// heavier tails than a normal distribution (worst-phase minima of noisy
/// frames), and with the whole budget the measured rate was 6.5 % (13 of
/// 200 comparisons, 20 repeats) and 5.5 % (11 of 200, 120 repeats); the
/// rest is the margin that keeps it within `alpha` (docs/campaigns.md,
/// "Measured").
pub const BUDGET: f64 = 0.8;

/// The trace-propagated sigma is multiplied by this when no repeated runs
/// give the real run-to-run spread: over repeated runs of the shipped
/// noisy plans, the spread of a KPI was up to this many times the sigma
/// propagated from the trace (docs/campaigns.md, "Measured").
pub const TRACE_INFLATION: f64 = 3.0;

/// The default practical floor of a KPI, as a share of its check's limit:
/// limits are stated to one or two significant figures (0.1, 15, 0.95),
/// so a change below 1 % of the limit is below the limit's own precision.
pub const FLOOR_OF_LIMIT: f64 = 0.01;

/// Smallest change that counts at all, relative to the KPI's size (at
/// least 1): below it two runs differ only by floating-point rounding.
const NUMERIC_FLOOR: f64 = 1e-9;

/// In a metric that regressed as a whole (its pooled score beyond the
/// gate), a case is named when its own change towards worse is beyond
/// this many standard deviations (and its floor).
const SYSTEMATIC_Z: f64 = 1.0;

/// The fewest degrees of freedom for which the repeats' spread is used:
/// below it Student's t is so wide (25 sigma at 2 degrees of freedom and
/// 8 gated KPIs, 7 at 6) that a third baseline run would make the gate
/// blind to a change the traces show; the traces are used instead.
pub const MIN_REPEAT_DF: usize = 6;

/// A KPI: (case id, ROI, metric).
pub type Key = (String, String, String);

/// How the gate is set.
#[derive(Debug, Clone)]
pub struct GateOptions {
    /// Chance of a false alarm over the whole comparison.
    pub alpha: f64,
    /// Metric -> smallest change towards worse that can be a regression,
    /// in the KPI's units; a metric not named has [`FLOOR_OF_LIMIT`] of
    /// its check's limit.
    pub min_change: BTreeMap<String, f64>,
    /// The user accepts the listed test differences (`--accept-changes`).
    pub accept_changes: bool,
}

impl Default for GateOptions {
    fn default() -> Self {
        GateOptions {
            alpha: ALPHA,
            min_change: BTreeMap::new(),
            accept_changes: false,
        }
    }
}

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
    fn spread(&self, f: impl Fn(&BTreeMap<Key, f64>) -> Option<f64>) -> Option<Spread> {
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
struct Spread {
    /// Pooled within-group standard deviation.
    sd: f64,
    /// Its degrees of freedom.
    df: usize,
    /// Each run's residual from its group's mean, in units of `sd`.
    residuals: Vec<f64>,
}

/// Excess kurtosis of residuals (0 for a normal distribution), at least
/// 0; 0 with fewer than 4.
fn excess_kurtosis(residuals: &[f64]) -> f64 {
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
fn effective_df(df: usize, runs: usize, excess: f64) -> usize {
    let v = 2.0 / (2.0 / df as f64 + excess / runs.max(1) as f64);
    (v.floor() as usize).clamp(1, df)
}

/// Where a KPI's sigma came from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Source {
    /// The spread over repeated runs, with its effective degrees of
    /// freedom and the excess kurtosis of the metric's values over them.
    Repeats(usize, f64),
    /// Both runs' traces, times [`TRACE_INFLATION`].
    Trace,
    /// A trace was not readable when its run was recorded: any change
    /// beyond the floor counts, and the KPI does not enter the pooled
    /// score.
    Unknown,
}

/// One KPI of one ROI of one case in both runs.
#[derive(Debug, Clone)]
pub struct Kpi {
    /// Case id.
    pub case: String,
    /// ROI name.
    pub roi: String,
    /// Metric name, as in results.json.
    pub metric: String,
    /// Its value in run A and in run B (`None`: undefined).
    pub a: Option<f64>,
    /// See `a`.
    pub b: Option<f64>,
    /// Standard deviation of `b - a` (0: noiseless); `None` when unknown.
    pub sigma: Option<f64>,
    /// The sigma of the change propagated from the two runs' traces
    /// (not inflated); `None` when a trace gave no noise.
    pub trace_sigma: Option<f64>,
    /// Where `sigma` came from.
    pub source: Source,
    /// The gate in standard deviations for this KPI.
    pub k: f64,
    /// The practical floor: a smaller change towards worse never counts.
    pub floor: f64,
    /// `+1`: a rise is worse (a `<=` check), `-1`: a fall is worse (`>=`);
    /// 0: no check judges this KPI, so it is reported, not gated.
    pub worse: i8,
    /// The change is beyond the gate, in the worse direction.
    pub regressed: bool,
    /// Regressed only as a case of a metric whose pooled change is beyond
    /// its gate (its own change is beyond 1 sigma and its floor, not
    /// beyond `k`).
    pub by_pool: bool,
}

impl Kpi {
    /// `b - a`, when both are defined and finite.
    pub fn delta(&self) -> Option<f64> {
        Some(self.b? - self.a?).filter(|d| d.is_finite())
    }

    /// The change in standard deviations of the difference (signed, worse
    /// positive); `None` without both values or without noise.
    pub fn z(&self) -> Option<f64> {
        let s = self.sigma.filter(|s| *s > 0.0)?;
        Some(self.delta()? * f64::from(self.worse) / s)
    }

    /// The change towards worse (negative: better).
    fn worse_change(&self) -> Option<f64> {
        Some(self.delta()? * f64::from(self.worse))
    }
}

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

/// How a metric's changes were pooled over its cases.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PoolMethod {
    /// Each run's weighted sum over the cases, its run-to-run spread
    /// measured over the repeats (any correlation between cases is in
    /// it), with Student's t at these degrees of freedom.
    RunSums(usize),
    /// The mean of the cases' standardised changes against a standard
    /// normal: valid whatever the correlation between cases, since the
    /// mean of standard normals has a variance of at most 1.
    MeanZ,
}

/// One metric's changes pooled over its cases.
#[derive(Debug, Clone)]
pub struct Pooled {
    /// Metric.
    pub metric: String,
    /// The pooled change towards worse, in standard deviations.
    pub score: f64,
    /// Its gate.
    pub gate: f64,
    /// Cases pooled.
    pub n: usize,
    /// How.
    pub method: PoolMethod,
    /// Beyond the gate and, summed over the cases, beyond the floors.
    pub regressed: bool,
}

/// Whether the two runs may be compared.
#[derive(Debug, Clone, PartialEq)]
pub enum Comparability {
    /// The same test: only the device or the run differs.
    Same,
    /// The tests differ, and the user accepted the differences.
    Accepted,
    /// Not comparable: why, and what the user can do (for the terminal;
    /// the customer's report shows the reason only).
    Not {
        /// The reason, one sentence.
        why: String,
        /// The hint.
        hint: String,
    },
}

/// The whole comparison.
#[derive(Debug, Clone)]
pub struct Comparison {
    /// Run A (the baseline) and run B.
    pub a: RunRow,
    /// See `a`.
    pub b: RunRow,
    /// What differs between the runs' set-ups, test keys first.
    pub differences: Vec<Difference>,
    /// Whether they may be compared.
    pub comparability: Comparability,
    /// The gate in standard deviations for a KPI whose sigma comes from
    /// the traces (repeats have their own, from Student's t).
    pub k: f64,
    /// Per metric gated with noise in two or more cases: its pooled score.
    pub pooled: Vec<Pooled>,
    /// Every KPI in both runs, in A's case order.
    pub kpis: Vec<Kpi>,
    /// Verdict flips, in A's case order.
    pub flips: Vec<Flip>,
    /// Cases in only one of the runs (or under other conditions).
    pub unmatched: Vec<String>,
    /// Repeated runs like A and like B in the database, A and B left out
    /// (one group, counted as like A, when A and B are of one device and
    /// firmware).
    pub repeats: (usize, usize),
    /// A and B are of one device and firmware: their repeats are one
    /// group.
    pub one_group: bool,
}

impl Comparison {
    /// Cases with a regressed KPI, in A's case order.
    pub fn regressed_cases(&self) -> Vec<&str> {
        let mut seen = BTreeSet::new();
        self.kpis
            .iter()
            .filter(|k| k.regressed && seen.insert(k.case.as_str()))
            .map(|k| k.case.as_str())
            .collect()
    }

    /// KPIs the gate judged.
    pub fn gated(&self) -> usize {
        self.kpis.iter().filter(|k| k.worse != 0).count()
    }

    /// Gated KPIs whose sigma came from repeats, and the fewest and most
    /// degrees of freedom among them.
    pub fn from_repeats(&self) -> (usize, usize, usize) {
        let dfs: Vec<usize> = self
            .kpis
            .iter()
            .filter(|k| k.worse != 0)
            .filter_map(|k| match k.source {
                Source::Repeats(df, _) => Some(df),
                _ => None,
            })
            .collect();
        (
            dfs.len(),
            dfs.iter().copied().min().unwrap_or(0),
            dfs.iter().copied().max().unwrap_or(0),
        )
    }

    /// The single-KPI gate in standard deviations, in words: one number,
    /// or the range over KPIs whose sigmas come from different numbers of
    /// repeats.
    pub fn gate_words(&self) -> String {
        let ks: Vec<f64> = self
            .kpis
            .iter()
            .filter(|k| k.worse != 0)
            .map(|k| k.k)
            .collect();
        let lo = ks.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = ks.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if ks.is_empty() {
            format!("{:.2}", self.k)
        } else if hi - lo < 0.005 {
            format!("{lo:.2}")
        } else {
            format!("{lo:.2} to {hi:.2}")
        }
    }

    /// The runs may be compared (the same test, or differences accepted)
    /// and share a gated KPI.
    pub fn is_comparable(&self) -> bool {
        !matches!(self.comparability, Comparability::Not { .. })
    }
}

/// Relative tolerance under which two case conditions are the same.
const SAME_CONDITION: f64 = 1e-9;

fn same_conditions(a: &CaseData, b: &CaseData) -> bool {
    let same = |x: f64, y: f64| (x - y).abs() <= SAME_CONDITION * x.abs().max(y.abs()).max(1.0);
    same(a.light_lux, b.light_lux) && same(a.frequency_hz, b.frequency_hz) && same(a.duty, b.duty)
}

/// Compares run B with the baseline A; `repeats` holds the runs of the
/// same test on A's and on B's device and firmware.
pub fn compare(a: &RunData, b: &RunData, repeats: &Repeats, opts: &GateOptions) -> Comparison {
    // Per KPI with enough repeats: its spread, for the tails below.
    let mut spreads: Vec<Option<Spread>> = Vec::new();
    let differences = match (&a.run.setup, &b.run.setup) {
        (Some(x), Some(y)) => setup::differences(x, y),
        _ => Vec::new(),
    };
    let mut kpis = Vec::new();
    let mut flips = Vec::new();
    let mut unmatched = Vec::new();
    let mut matched = 0usize;
    for id in &a.order {
        let (Some(ca), Some(cb)) = (a.cases.get(id), b.cases.get(id)) else {
            unmatched.push(id.clone());
            continue;
        };
        if !same_conditions(ca, cb) {
            unmatched.push(format!("{id} (its conditions differ)"));
            continue;
        }
        matched += 1;
        if ca.verdict != cb.verdict {
            flips.push(Flip {
                case: id.clone(),
                from: ca.verdict.clone(),
                to: cb.verdict.clone(),
                cause: FlipCause::WithinNoise,
            });
        }
        // A case judged in neither run (outside the mitigation range, or
        // informative) has checks for information only: nothing to gate.
        let judged = ca.verdict != "info" || cb.verdict != "info";
        for (roi, ra) in &ca.rois {
            let Some(rb) = cb.rois.get(roi) else { continue };
            for (metric, va) in &ra.metrics {
                let Some(vb) = rb.metrics.get(metric) else {
                    continue;
                };
                let key = (id.clone(), roi.clone(), metric.clone());
                let (worse, limit) = match judged {
                    true => check_of(ca, roi, metric)
                        .or_else(|| check_of(cb, roi, metric))
                        .unwrap_or((0, None)),
                    false => (0, None),
                };
                let trace_sigma = match (sigma_of(metric, ra, *va), sigma_of(metric, rb, *vb)) {
                    (Some(x), Some(y)) => Some(x.hypot(y)),
                    _ => None,
                };
                let spread = repeats
                    .spread(|v| v.get(&key).copied())
                    .filter(|sp| sp.df >= MIN_REPEAT_DF);
                let (sigma, source) = match &spread {
                    // The degrees of freedom and tails are settled below,
                    // once every KPI's residuals are known.
                    Some(sp) => (
                        Some(sp.sd * std::f64::consts::SQRT_2),
                        Source::Repeats(sp.df, 0.0),
                    ),
                    None => match trace_sigma {
                        Some(t) => (Some(TRACE_INFLATION * t), Source::Trace),
                        None => (None, Source::Unknown),
                    },
                };
                let floor = opts
                    .min_change
                    .get(metric)
                    .copied()
                    .unwrap_or_else(|| limit.map_or(0.0, |l| FLOOR_OF_LIMIT * l.abs()));
                kpis.push(Kpi {
                    case: id.clone(),
                    roi: roi.clone(),
                    metric: metric.clone(),
                    a: va.filter(|v| !v.is_nan()),
                    b: vb.filter(|v| !v.is_nan()),
                    sigma,
                    trace_sigma,
                    source,
                    k: 0.0,
                    floor,
                    worse,
                    regressed: false,
                    by_pool: false,
                });
                spreads.push(spread);
            }
        }
    }
    let excess = tails_by_metric(&kpis, &spreads);
    for (kpi, sp) in kpis.iter_mut().zip(&spreads) {
        if let Some(sp) = sp {
            let tails = excess.get(kpi.metric.as_str()).copied().unwrap_or(0.0);
            kpi.source = Source::Repeats(effective_df(sp.df, sp.residuals.len(), tails), tails);
        }
    }
    unmatched.extend(
        b.order
            .iter()
            .filter(|id| !a.cases.contains_key(*id))
            .cloned(),
    );
    // Half the false-alarm budget for single KPIs (Bonferroni over them),
    // half for the pooled scores (Bonferroni over the metrics): a union
    // bound keeps the whole comparison's rate at most `alpha`.
    let gated = kpis.iter().filter(|k| k.worse != 0).count().max(1);
    let alpha = BUDGET * opts.alpha;
    let tail = alpha / 2.0 / gated as f64;
    let k = normal_quantile(1.0 - tail);
    for kpi in &mut kpis {
        kpi.k = match kpi.source {
            Source::Repeats(df, tails) => repeats_gate(1.0 - tail, df, tails),
            _ => k,
        };
    }
    let pooled = pooled_scores(&kpis, a, b, repeats, &excess, alpha);
    for kpi in &mut kpis {
        let shifted = pooled.iter().any(|p| p.metric == kpi.metric && p.regressed);
        let systematic = shifted
            && kpi.z().is_some_and(|z| z > SYSTEMATIC_Z)
            && kpi.worse_change().is_some_and(|c| c > kpi.floor);
        let alone = regressed(kpi, b.cases.get(&kpi.case));
        kpi.regressed = alone || systematic;
        kpi.by_pool = systematic && !alone;
    }
    let regressed_cases: BTreeSet<&str> = kpis
        .iter()
        .filter(|k| k.regressed)
        .map(|k| k.case.as_str())
        .collect();
    for f in &mut flips {
        let (ca, cb) = (&a.cases[&f.case], &b.cases[&f.case]);
        f.cause = if let Some(what) = limit_change(ca, cb) {
            FlipCause::LimitChanged(what)
        } else if (ca.verdict == "info") != (cb.verdict == "info") {
            FlipCause::JudgedInOneRun
        } else if regressed_cases.contains(f.case.as_str()) {
            FlipCause::Regressed
        } else {
            FlipCause::WithinNoise
        };
    }
    let comparability = comparability(a, b, &differences, matched, &kpis, opts);
    Comparison {
        a: a.run.clone(),
        b: b.run.clone(),
        differences,
        comparability,
        k,
        pooled,
        kpis,
        flips,
        unmatched,
        repeats: (repeats.count(0), repeats.count(1)),
        one_group: repeats.one_group,
    }
}

/// The gate at one-sided level `p` for a change whose sigma is measured
/// over repeats: Student's t at `df`, widened by the Cornish-Fisher term
/// of the change's excess kurtosis. The difference of two runs has half
/// the runs' excess kurtosis `tails` (and no skew, whatever theirs), and
/// heavy tails put more of it beyond the normal quantile `z`:
/// `(z^3 - 3 z) kurtosis / 24`.
fn repeats_gate(p: f64, df: usize, tails: f64) -> f64 {
    let z = normal_quantile(p);
    t_quantile(p, df) + (z.powi(3) - 3.0 * z).max(0.0) * (tails / 2.0) / 24.0
}

/// Per metric, the excess kurtosis of the standardised residuals over the
/// repeats of its gated KPIs with a spread (a KPI with none, and an
/// ungated one such as a background ROI's, says nothing of the gated
/// values' tails), pooled over its cases and ROIs: one KPI's few runs say
/// little about its tails.
fn tails_by_metric(kpis: &[Kpi], spreads: &[Option<Spread>]) -> BTreeMap<String, f64> {
    let mut residuals: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
    for (kpi, sp) in kpis.iter().zip(spreads) {
        if let Some(sp) = sp.as_ref().filter(|sp| sp.sd > 0.0 && kpi.worse != 0) {
            residuals
                .entry(kpi.metric.as_str())
                .or_default()
                .extend(&sp.residuals);
        }
    }
    residuals
        .into_iter()
        .map(|(m, r)| (m.to_string(), excess_kurtosis(&r)))
        .collect()
}

/// Same test, accepted differences, or not comparable (and why).
fn comparability(
    a: &RunData,
    b: &RunData,
    differences: &[Difference],
    matched: usize,
    kpis: &[Kpi],
    opts: &GateOptions,
) -> Comparability {
    if matched == 0 {
        return Comparability::Not {
            why: format!(
                "runs {} and {} share no case (the same id under the same conditions)",
                a.run.id, b.run.id
            ),
            hint: "compare runs of the same plan; `ledflicker history --plan ID` lists them"
                .to_string(),
        };
    }
    if !kpis.iter().any(|k| k.worse != 0) {
        return Comparability::Not {
            why: format!(
                "runs {} and {} share no KPI that a check judges in either run: there is nothing to gate",
                a.run.id, b.run.id
            ),
            hint: "a KPI is gated when a plan threshold checks it in a judged case".to_string(),
        };
    }
    let unknown: Vec<String> = [&a.run, &b.run]
        .iter()
        .filter(|r| r.setup.is_none())
        .map(|r| r.id.to_string())
        .collect();
    let tests = differences
        .iter()
        .filter(|d| d.kind == Kind::Test.as_str())
        .count();
    let why = if !unknown.is_empty() {
        format!(
            "the set-up of run {} was not recorded (recorded before ledflicker.db/2), so its test cannot be checked against the other's",
            unknown.join(" and run ")
        )
    } else if tests > 0 {
        format!("{tests} setting(s) of the test differ: the runs are different tests")
    } else {
        return Comparability::Same;
    };
    match opts.accept_changes {
        true => Comparability::Accepted,
        false => Comparability::Not {
            why,
            hint: "pass --accept-changes to compare them anyway; verdict flips caused by a changed limit are then named as such".to_string(),
        },
    }
}

/// The check on this KPI in `case`: which way is worse (`<=`: a rise,
/// `>=`: a fall) and its limit.
fn check_of(case: &CaseData, roi: &str, metric: &str) -> Option<(i8, Option<f64>)> {
    case.checks
        .iter()
        .find(|c| c.roi == roi && c.metric == metric)
        .map(|c| {
            let worse = if c.comparison == "<=" { 1 } else { -1 };
            (worse, Some(c.threshold))
        })
}

/// The limits of a case that differ between A and B, in words; `None`
/// when they are the same.
fn limit_change(a: &CaseData, b: &CaseData) -> Option<String> {
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

/// Per metric gated with noise in at least two cases, in name order: its
/// pooled change towards worse and gate (see [`PoolMethod`]).
fn pooled_scores(
    kpis: &[Kpi],
    a: &RunData,
    b: &RunData,
    repeats: &Repeats,
    excess: &BTreeMap<String, f64>,
    alpha: f64,
) -> Vec<Pooled> {
    let mut by: BTreeMap<&str, Vec<&Kpi>> = BTreeMap::new();
    for k in kpis
        .iter()
        .filter(|k| k.worse != 0 && k.z().is_some() && k.source != Source::Unknown)
    {
        by.entry(k.metric.as_str()).or_default().push(k);
    }
    by.retain(|_, v| v.len() >= 2);
    let tail = alpha / 2.0 / by.len().max(1) as f64;
    by.into_iter()
        .map(|(metric, cases)| {
            let floors: f64 = cases.iter().map(|k| k.floor).sum();
            let changes: f64 = cases.iter().filter_map(|k| k.worse_change()).sum();
            let tails = excess.get(metric).copied().unwrap_or(0.0);
            let (score, gate, method) = match run_sums(&cases, a, b, repeats, tails) {
                Some((t, df, tails)) => (
                    t,
                    repeats_gate(1.0 - tail, df, tails),
                    PoolMethod::RunSums(df),
                ),
                None => {
                    // Each z as a standard normal score (a z over a sigma
                    // from few repeats is Student's t: heavier tails).
                    let zs: Vec<f64> = cases
                        .iter()
                        .filter_map(|k| {
                            let z = k.z()?;
                            Some(match k.source {
                                Source::Repeats(df, _) => t_to_normal(z, df),
                                _ => z,
                            })
                        })
                        .collect();
                    let mean = zs.iter().sum::<f64>() / zs.len() as f64;
                    (mean, normal_quantile(1.0 - tail), PoolMethod::MeanZ)
                }
            };
            Pooled {
                metric: metric.to_string(),
                score,
                gate,
                n: cases.len(),
                method,
                regressed: score > gate && changes > floors,
            }
        })
        .collect()
}

/// The pooled score over repeats: each run's sum over the cases of its
/// values towards worse in units of each case's spread, B's sum minus A's
/// over `sqrt(2)` times the sums' run-to-run spread, with its degrees of
/// freedom. `None` unless every case's sigma is from repeats and at least
/// one group has two runs with every case defined.
fn run_sums(
    cases: &[&Kpi],
    a: &RunData,
    b: &RunData,
    repeats: &Repeats,
    metric_tails: f64,
) -> Option<(f64, usize, f64)> {
    // Each case weighs by the inverse of its trace noise when every case
    // has one: weights taken from the repeats themselves would fit their
    // sample (a case whose spread came out small by chance weighs more,
    // and the sums' spread over the same repeats then understates the
    // change's), which measured 3.1 % false alarms for a 2.5 % budget on
    // normal values.
    let by_trace = cases.iter().all(|k| k.trace_sigma.is_some_and(|s| s > 0.0));
    let mut weights = Vec::new();
    for k in cases {
        let Source::Repeats(..) = k.source else {
            return None;
        };
        let s = match by_trace {
            true => k.trace_sigma?,
            false => k.sigma?,
        };
        weights.push((
            (k.case.clone(), k.roi.clone(), k.metric.clone()),
            f64::from(k.worse) / s,
        ));
    }
    let sum = |get: &dyn Fn(&Key) -> Option<f64>| -> Option<f64> {
        weights
            .iter()
            .map(|(key, w)| get(key).filter(|x| x.is_finite()).map(|x| w * x))
            .sum()
    };
    let value = |run: &RunData, key: &Key| {
        run.cases
            .get(&key.0)?
            .rois
            .get(&key.1)?
            .metrics
            .get(&key.2)
            .copied()
            .flatten()
    };
    let sa = sum(&|key| value(a, key))?;
    let sb = sum(&|key| value(b, key))?;
    let sp = repeats
        .spread(|v| sum(&|key| v.get(key).copied()))
        .filter(|sp| sp.df >= MIN_REPEAT_DF)?;
    let tails = excess_kurtosis(&sp.residuals).max(metric_tails);
    let df = effective_df(sp.df, sp.residuals.len(), tails);
    (sp.sd > 0.0).then(|| ((sb - sa) / (sp.sd * std::f64::consts::SQRT_2), df, tails))
}

/// The gate for one KPI: a change towards worse beyond its floor and
/// beyond `k` sigma; a value lost in B (undefined, or unbounded towards
/// worse) whose check fails there is a regression too.
fn regressed(kpi: &Kpi, case_b: Option<&CaseData>) -> bool {
    if kpi.worse == 0 {
        return false;
    }
    let fails_in_b = || {
        case_b.is_some_and(|c| {
            c.checks
                .iter()
                .any(|x| x.roi == kpi.roi && x.metric == kpi.metric && !x.pass)
        })
    };
    match (kpi.a, kpi.b) {
        (Some(a), Some(b)) if a.is_finite() && b.is_finite() => {
            let change = (b - a) * f64::from(kpi.worse);
            let rounding = NUMERIC_FLOOR * a.abs().max(b.abs()).max(1.0);
            change > kpi.floor && change > kpi.k * kpi.sigma.unwrap_or(0.0) + rounding
        }
        // Unbounded towards worse in B, not in A.
        (a, Some(b)) if b.is_infinite() => {
            b * f64::from(kpi.worse) > 0.0 && a.is_none_or(|a| a != b)
        }
        (Some(a), None) if a.is_finite() => fails_in_b(),
        _ => false,
    }
}

/// Standard deviation of one run's KPI from its ROI's frame noise,
/// propagated to first order through the KPI's formula
/// (docs/campaigns.md, "Where sigma comes from"). The PWM extremes `min`
/// and `max` are single frames, each as noisy as a frame at its level; the
/// OFF reference is the mean of the OFF frames.
pub fn sigma_of(metric: &str, roi: &RoiData, value: Option<f64>) -> Option<f64> {
    let (min, max) = (roi.level_min, roi.level_max);
    let at_min = frame_noise(roi, min)?;
    let at_max = frame_noise(roi, max)?;
    let out = match metric {
        // PF = 100 (max - min) / (max + min)
        "percent_flicker" | "percent_flicker_worst_phase" => {
            let sum = max + min;
            (sum > 0.0).then(|| 200.0 * (max * at_min).hypot(min * at_max) / (sum * sum))
        }
        // FDI = (min - off) / off
        "fdi_2018" | "fdi_2018_worst_phase" => {
            let off = roi.level_off.filter(|off| *off > 0.0)?;
            let off_mean = roi.noise_off_dn? / (roi.off_frames.max(1) as f64).sqrt();
            Some((at_min / off).hypot(min * off_mean / (off * off)))
        }
        // A contrast of levels near `max`: its relative uncertainty is
        // about that of the difference of two frames.
        _ => value.map(|v| {
            v.abs() * std::f64::consts::SQRT_2 * at_max / max.abs().max(f64::MIN_POSITIVE)
        }),
    };
    out.filter(|v| v.is_finite())
}

/// Noise of one frame at luma `level`: shot noise makes the variance grow
/// linearly with the light, so it is interpolated (and extrapolated) in
/// variance between the OFF and the ON segment's, by level. With one
/// segment's noise only, that noise.
fn frame_noise(roi: &RoiData, level: f64) -> Option<f64> {
    match (
        roi.noise_off_dn,
        roi.noise_on_dn,
        roi.level_off,
        roi.level_on,
    ) {
        (Some(s_off), Some(s_on), Some(off), Some(on)) if on != off => {
            let t = (level - off) / (on - off);
            Some(
                (s_off * s_off + (s_on * s_on - s_off * s_off) * t)
                    .max(0.0)
                    .sqrt(),
            )
        }
        (a, b, _, _) => a.or(b),
    }
}

/// Student's t quantile at `p` in (0, 1) with `df` degrees of freedom
/// (`df >= 1`), by bisection on [`t_upper`]: the gate of a KPI whose sigma
/// is estimated from `df + 1` or more repeated runs.
pub fn t_quantile(p: f64, df: usize) -> f64 {
    if p < 0.5 {
        return -t_quantile(1.0 - p, df);
    }
    let upper = 1.0 - p;
    if df == 0 || upper <= 0.0 {
        return f64::INFINITY;
    }
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    while t_upper(hi, df) > upper {
        lo = hi;
        hi *= 2.0;
        if hi > 1e12 {
            return f64::INFINITY;
        }
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if t_upper(mid, df) > upper {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-12 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// `P(T > t)` for Student's t with `df` degrees of freedom, `t >= 0`:
/// `I_x(df/2, 1/2) / 2` with `x = df / (df + t^2)`.
pub fn t_upper(t: f64, df: usize) -> f64 {
    let v = df as f64;
    0.5 * regularized_beta(v / 2.0, 0.5, v / (v + t * t))
}

/// A Student's t score as the standard normal score of the same tail.
fn t_to_normal(t: f64, df: usize) -> f64 {
    let tail = t_upper(t.abs(), df).max(1e-300);
    let z = -normal_quantile(tail);
    if t < 0.0 { -z } else { z }
}

/// The regularised incomplete beta function `I_x(a, b)`, by its continued
/// fraction (evaluated with the modified Lentz method), on the side of
/// `x` where it converges fast.
fn regularized_beta(a: f64, b: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let front =
        (ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln()).exp();
    if x < (a + 1.0) / (a + b + 2.0) {
        front * beta_fraction(a, b, x) / a
    } else {
        1.0 - front * beta_fraction(b, a, 1.0 - x) / b
    }
}

fn beta_fraction(a: f64, b: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let mut c = 1.0;
    let mut d = 1.0 - (a + b) * x / (a + 1.0);
    if d.abs() < TINY {
        d = TINY;
    }
    d = 1.0 / d;
    let mut h = d;
    for m in 1..=300 {
        let m = m as f64;
        for num in [
            m * (b - m) * x / ((a + 2.0 * m - 1.0) * (a + 2.0 * m)),
            -(a + m) * (a + b + m) * x / ((a + 2.0 * m) * (a + 2.0 * m + 1.0)),
        ] {
            d = 1.0 + num * d;
            if d.abs() < TINY {
                d = TINY;
            }
            c = 1.0 + num / c;
            if c.abs() < TINY {
                c = TINY;
            }
            d = 1.0 / d;
            h *= d * c;
        }
        if (d * c - 1.0).abs() < 1e-15 {
            break;
        }
    }
    h
}

/// `ln Γ(x)` for `x > 0` (Lanczos' approximation, g = 7, 9 terms;
/// relative error about 1e-15).
fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let t = x + 7.5;
    let mut s = C[0];
    for (i, c) in C.iter().enumerate().skip(1) {
        s += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + s.ln()
}

/// The standard normal quantile at `p` in (0, 1) (Acklam's rational
/// approximation, relative error below 1.2e-9): the gate's `k`.
pub fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] = [
        7.784_695_709_041_462e-3,
        3.224_671_290_700_398e-1,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    let p = p.clamp(1e-300, 1.0 - 1e-16);
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < 0.024_25 {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - 0.024_25 {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::campaign::query::CheckData;

    #[test]
    fn the_normal_quantile_matches_tabulated_values() {
        for (p, z) in [
            (0.5, 0.0),
            (0.975, 1.959_963_985),
            (0.95, 1.644_853_627),
            (1.0 - 0.05 / 70.0, 3.188_815_259),
            (0.001, -3.090_232_306),
        ] {
            assert!(
                (normal_quantile(p) - z).abs() < 1e-5,
                "{p}: {}",
                normal_quantile(p)
            );
        }
    }

    #[test]
    fn percent_flicker_uncertainty_matches_a_finite_difference() {
        // The same noise at every level.
        let roi = RoiData {
            level_min: 40.0,
            level_max: 200.0,
            noise_on_dn: Some(1.0),
            noise_off_dn: Some(1.0),
            ..Default::default()
        };
        let pf = |min: f64, max: f64| 100.0 * (max - min) / (max + min);
        let h = 1e-4;
        let dmin = (pf(40.0 + h, 200.0) - pf(40.0 - h, 200.0)) / (2.0 * h);
        let dmax = (pf(40.0, 200.0 + h) - pf(40.0, 200.0 - h)) / (2.0 * h);
        let s = sigma_of("percent_flicker", &roi, None).unwrap();
        assert!((s - dmin.hypot(dmax)).abs() < 1e-6, "{s}");
    }

    #[test]
    fn frame_noise_follows_shot_noise_between_the_off_and_on_levels() {
        let roi = RoiData {
            level_off: Some(10.0),
            level_on: Some(110.0),
            noise_off_dn: Some(1.0),
            noise_on_dn: Some(3.0),
            ..Default::default()
        };
        // Variance 1 at 10 DN, 9 at 110 DN: 5 halfway.
        assert!((frame_noise(&roi, 60.0).unwrap() - 5f64.sqrt()).abs() < 1e-12);
        assert!((frame_noise(&roi, 10.0).unwrap() - 1.0).abs() < 1e-12);
        let on_only = RoiData {
            noise_on_dn: Some(2.0),
            ..Default::default()
        };
        assert_eq!(frame_noise(&on_only, 5.0), Some(2.0));
        assert_eq!(frame_noise(&RoiData::default(), 5.0), None);
    }

    #[test]
    fn the_t_quantile_matches_tabulated_values_and_tends_to_the_normal() {
        for (p, df, t) in [
            (0.975, 1, 12.706_204_736),
            (0.975, 2, 4.302_652_730),
            (0.95, 5, 2.015_048_373),
            (0.995, 10, 3.169_272_673),
            (0.9995, 30, 3.645_959_540),
        ] {
            let got = t_quantile(p, df);
            assert!((got - t).abs() < 1e-6 * t, "t({p}, {df}) = {got}, not {t}");
        }
        let z = normal_quantile(0.999);
        assert!((t_quantile(0.999, 100_000) - z).abs() < 1e-3);
        assert!((t_to_normal(t_quantile(0.99, 4), 4) - normal_quantile(0.99)).abs() < 1e-6);
    }

    fn row(id: i64) -> RunRow {
        RunRow {
            id,
            recorded_unix_s: 0,
            source: "plan".into(),
            date: String::new(),
            plan_id: "p".into(),
            plan_title: String::new(),
            plan_hash: String::new(),
            seed: 0,
            tool: String::new(),
            backend: String::new(),
            supplier: String::new(),
            model: String::new(),
            serial: String::new(),
            firmware: String::new(),
            signer: None,
            signature: "unsigned".into(),
            report_dir: String::new(),
            results_sha256: String::new(),
            manifest_sha256: None,
            verdict: "pass".into(),
            cases: [0; 4],
            setup: Some(setup::Setup::default()),
            test_hash: Some(String::new()),
        }
    }

    /// A run of `fdi.len()` cases, each with one gated KPI `fdi_2018`
    /// (`>= 0.1`) of the given value, and trace noise giving each run's
    /// KPI a sigma of 0.0447.
    fn run(id: i64, fdi: &[f64]) -> RunData {
        let mut cases = BTreeMap::new();
        let mut order = Vec::new();
        for (i, v) in fdi.iter().enumerate() {
            // OFF at 10 DN from 16 frames of noise 0.4 DN, min at 20 DN of
            // noise 0.4 DN: sigma(FDI) = hypot(0.04, 0.02) = 0.0447.
            let roi = RoiData {
                kind: "led".into(),
                level_min: 20.0,
                level_max: 40.0,
                level_off: Some(10.0),
                level_on: Some(30.0),
                noise_on_dn: Some(0.4),
                noise_off_dn: Some(0.4),
                off_frames: 16,
                metrics: [("fdi_2018".to_string(), Some(*v))].into(),
            };
            let check = CheckData {
                roi: "led".into(),
                metric: "fdi_2018".into(),
                comparison: ">=".into(),
                threshold: 0.1,
                pass: *v >= 0.1,
            };
            let id = format!("c{i}");
            order.push(id.clone());
            cases.insert(
                id,
                CaseData {
                    verdict: if *v >= 0.1 { "pass" } else { "fail" }.into(),
                    rois: [("led".to_string(), roi)].into(),
                    checks: vec![check],
                    ..Default::default()
                },
            );
        }
        RunData {
            run: row(id),
            order,
            cases,
        }
    }

    fn gate(a: &RunData, b: &RunData) -> Comparison {
        compare(a, b, &Repeats::default(), &GateOptions::default())
    }

    #[test]
    fn without_repeats_the_trace_sigma_is_inflated_and_the_pooled_mean_holds_under_dependence() {
        let sigma = TRACE_INFLATION * 0.0447_f64.hypot(0.0447);
        let a = run(1, &[1.0; 16]);
        let same = gate(&a, &a);
        assert!(same.regressed_cases().is_empty());
        assert!(same.is_comparable());
        assert_eq!(same.pooled.len(), 1);
        assert_eq!(same.pooled[0].method, PoolMethod::MeanZ);
        // Every case 1.5 sd worse: no single case beyond k (3.02 for 16
        // KPIs), and a mean z of 1.5 is within the pooled gate 2.05, as it
        // must be when the 16 cases move together (one run-wide effect).
        let c = gate(&a, &run(2, &[1.0 - 1.5 * sigma; 16]));
        assert!((c.kpis[0].sigma.unwrap() - sigma).abs() < 1e-3);
        assert!(c.k > 2.9 && c.k < 3.1, "{}", c.k);
        assert!((c.pooled[0].gate - 2.053_749).abs() < 1e-5);
        assert!((c.pooled[0].score - 1.5).abs() < 0.01, "{:?}", c.pooled);
        assert!(c.regressed_cases().is_empty());
        // 2.5 sd in every case: the metric regressed as a whole.
        let c = gate(&a, &run(3, &[1.0 - 2.5 * sigma; 16]));
        assert!(c.pooled[0].regressed);
        assert_eq!(c.regressed_cases().len(), 16);
        // One case 4 sd worse: that case alone; the same change for the
        // better is no regression.
        let mut one = vec![1.0; 16];
        one[3] = 1.0 - 4.0 * sigma;
        assert_eq!(gate(&a, &run(4, &one)).regressed_cases(), ["c3"]);
        one[3] = 1.0 + 4.0 * sigma;
        assert!(gate(&a, &run(5, &one)).regressed_cases().is_empty());
    }

    /// Runs 10.. of `cases` KPIs: value 1 + g_r + e_rc, `g_r` a per-run
    /// effect shared by every case, from a fixed pseudo-random sequence.
    fn correlated_repeats(runs: usize, cases: usize, g_sd: f64, e_sd: f64) -> Repeats {
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut normal = move || {
            // Sum of 12 uniforms minus 6: a standard normal to 1e-2.
            (0..12)
                .map(|_| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    (state >> 11) as f64 / (1u64 << 53) as f64
                })
                .sum::<f64>()
                - 6.0
        };
        let mut out = Repeats::default();
        for r in 0..runs {
            let g = g_sd * normal();
            let values = (0..cases)
                .map(|c| {
                    let key = (format!("c{c}"), "led".to_string(), "fdi_2018".to_string());
                    (key, 1.0 + g + e_sd * normal())
                })
                .collect();
            out.runs.push((0, 10 + r as i64, values));
        }
        out
    }

    #[test]
    fn repeats_give_the_sigma_and_students_t_and_a_run_wide_effect_is_no_regression() {
        let reps = correlated_repeats(12, 16, 0.05, 0.01);
        let a = run(1, &[1.0; 16]);
        let opts = GateOptions::default();
        let c = compare(&a, &a, &reps, &opts);
        assert_eq!(c.from_repeats().0, 16);
        let sd = reps.spread(|v| {
            v.get(&("c0".into(), "led".into(), "fdi_2018".into()))
                .copied()
        });
        let sp = sd.unwrap();
        assert_eq!(sp.df, 11);
        assert!((c.kpis[0].sigma.unwrap() - sp.sd * std::f64::consts::SQRT_2).abs() < 1e-12);
        // Near-normal values: the effective degrees of freedom stay near 11.
        let Source::Repeats(df, tails) = c.kpis[0].source else {
            panic!("{:?}", c.kpis[0].source)
        };
        assert!((8..=11).contains(&df), "{df}");
        assert!((c.kpis[0].k - repeats_gate(1.0 - 0.02 / 16.0, df, tails)).abs() < 1e-12);
        assert!(repeats_gate(0.999, 11, 0.0) == t_quantile(0.999, 11));
        // Every case 0.06 worse: about one run-wide effect's size. Pooled
        // as if the cases were independent (Stouffer) this is 16 times
        // 0.8 sd over sqrt(16): 3.3 sd, a false alarm; each run's sum
        // over the cases carries the shared effect in its spread, so it
        // is within the gate.
        let b = run(2, &[1.0 - 0.06; 16]);
        let c = compare(&a, &b, &reps, &opts);
        assert!(matches!(c.pooled[0].method, PoolMethod::RunSums(_)));
        let stouffer: f64 = c.kpis.iter().map(|k| k.z().unwrap()).sum::<f64>() / 4.0;
        assert!(stouffer > 2.5, "{stouffer}");
        assert!(c.pooled[0].score < c.pooled[0].gate, "{:?}", c.pooled);
        assert!(c.regressed_cases().is_empty());
        // Far beyond the run-to-run effect: a regression.
        let c = compare(&a, &run(3, &[1.0 - 0.5; 16]), &reps, &opts);
        assert_eq!(c.regressed_cases().len(), 16);
    }

    #[test]
    fn too_few_repeats_leave_the_traces_and_equal_values_spread_by_exactly_zero() {
        let a = run(1, &[1.0; 4]);
        let opts = GateOptions::default();
        // MIN_REPEAT_DF - 1 degrees of freedom: the traces.
        let few = correlated_repeats(MIN_REPEAT_DF, 4, 0.05, 0.01);
        let c = compare(&a, &a, &few, &opts);
        assert_eq!(c.from_repeats().0, 0);
        assert!(c.kpis.iter().all(|k| k.source == Source::Trace));
        let enough = correlated_repeats(MIN_REPEAT_DF + 1, 4, 0.05, 0.01);
        assert_eq!(compare(&a, &a, &enough, &opts).from_repeats().0, 4);
        // Ten runs of one value whose computed mean is off in the last bit.
        let key: Key = ("c0".into(), "led".into(), "fdi_2018".into());
        let mut same = Repeats::default();
        for r in 0..10 {
            same.runs.push((0, r, [(key.clone(), 0.1 + 0.2)].into()));
        }
        let sp = same.spread(|v| v.get(&key).copied()).unwrap();
        assert_eq!(sp.sd, 0.0);
        assert_eq!(sp.df, 9);
    }

    #[test]
    fn heavy_tails_lower_the_effective_degrees_of_freedom() {
        assert_eq!(effective_df(17, 18, 0.0), 17);
        // Laplace-like tails (excess kurtosis 3) from 18 runs: 2 / (2/17
        // + 3/18) = 7.03.
        assert_eq!(effective_df(17, 18, 3.0), 7);
        assert_eq!(effective_df(119, 120, 3.0), 47);
        assert_eq!(excess_kurtosis(&[1.0, -1.0, 1.0, -1.0]), 0.0);
        // One value far out among many small ones: heavy tails.
        let mut r = vec![0.1; 50];
        r.push(5.0);
        assert!(excess_kurtosis(&r) > 10.0);
    }

    #[test]
    fn a_change_below_its_floor_is_never_a_regression_even_without_noise() {
        let quiet = |id, v: f64| {
            let mut r = run(id, &[v; 2]);
            for c in r.cases.values_mut() {
                for roi in c.rois.values_mut() {
                    roi.noise_on_dn = Some(0.0);
                    roi.noise_off_dn = Some(0.0);
                }
            }
            r
        };
        let a = quiet(1, 1.0);
        // Default floor: 1 % of the limit 0.1.
        assert!(
            gate(&a, &quiet(2, 1.0 - 0.0009))
                .regressed_cases()
                .is_empty()
        );
        assert_eq!(gate(&a, &quiet(3, 1.0 - 0.0011)).regressed_cases().len(), 2);
        let opts = GateOptions {
            min_change: [("fdi_2018".to_string(), 0.01)].into(),
            ..GateOptions::default()
        };
        let c = compare(&a, &quiet(3, 1.0 - 0.005), &Repeats::default(), &opts);
        assert!(c.regressed_cases().is_empty());
    }

    #[test]
    fn a_value_lost_or_unbounded_towards_worse_in_b_is_a_regression() {
        let a = run(1, &[1.0, 1.0]);
        let mut b = run(2, &[1.0, 1.0]);
        let c0 = b.cases.get_mut("c0").unwrap();
        c0.rois
            .get_mut("led")
            .unwrap()
            .metrics
            .insert("fdi_2018".into(), Some(f64::NEG_INFINITY));
        c0.checks[0].pass = false;
        let c1 = b.cases.get_mut("c1").unwrap();
        c1.rois
            .get_mut("led")
            .unwrap()
            .metrics
            .insert("fdi_2018".into(), None);
        c1.checks[0].pass = false;
        assert_eq!(gate(&a, &b).regressed_cases(), ["c0", "c1"]);
        // Unbounded towards better is not.
        let mut b = run(3, &[1.0, 1.0]);
        let c0 = b.cases.get_mut("c0").unwrap();
        c0.rois
            .get_mut("led")
            .unwrap()
            .metrics
            .insert("fdi_2018".into(), Some(f64::INFINITY));
        assert!(gate(&a, &b).regressed_cases().is_empty());
    }

    #[test]
    fn runs_of_different_tests_or_without_a_shared_case_are_not_comparable() {
        let a = run(1, &[1.0; 3]);
        let mut other = run(2, &[1.0; 3]);
        other.order = vec!["x".into()];
        other.cases = [("x".to_string(), a.cases["c0"].clone())].into();
        assert!(
            matches!(gate(&a, &other).comparability, Comparability::Not { why, .. } if why.contains("share no case"))
        );
        // A limit changed: not comparable unless accepted, and the flips
        // it causes are named as such.
        let mut b = run(3, &[0.5; 3]);
        for c in b.cases.values_mut() {
            c.checks[0].threshold = 0.6;
            c.checks[0].pass = false;
            c.verdict = "fail".into();
        }
        let with = |key: &str, v: &str| {
            let mut s = setup::Setup::default();
            s.0.insert(key.into(), v.into());
            s
        };
        let mut a2 = run(4, &[0.5; 3]);
        a2.run.setup = Some(with("thresholds.fdi-2018-min", "0.1"));
        b.run.setup = Some(with("thresholds.fdi-2018-min", "0.6"));
        let c = gate(&a2, &b);
        assert!(
            matches!(&c.comparability, Comparability::Not { hint, .. } if hint.contains("--accept-changes"))
        );
        assert_eq!(c.differences.len(), 1);
        let opts = GateOptions {
            accept_changes: true,
            ..GateOptions::default()
        };
        let c = compare(&a2, &b, &Repeats::default(), &opts);
        assert_eq!(c.comparability, Comparability::Accepted);
        assert_eq!(c.flips.len(), 3);
        assert!(
            matches!(&c.flips[0].cause, FlipCause::LimitChanged(w) if w.contains(">= 0.1 -> >= 0.6"))
        );
        assert!(c.regressed_cases().is_empty());
        // A run recorded without its set-up cannot be checked.
        let mut old = run(5, &[1.0; 3]);
        old.run.setup = None;
        assert!(
            matches!(gate(&old, &a).comparability, Comparability::Not { why, .. } if why.contains("not recorded"))
        );
    }
}
