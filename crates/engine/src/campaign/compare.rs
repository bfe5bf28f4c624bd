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

use ledflicker_results::comparison::{self, Cases, Direction, Lead, Lookup, Pair, Tolerance};

use super::flips::limit_change;
pub use super::flips::{Flip, FlipCause};
use super::noise::sigma_of;
use super::query::{CaseData, RunData, RunRow};
pub use super::repeats::{Key, Repeats};
use super::repeats::{Spread, effective_df, excess_kurtosis};
use super::setup::{self, Difference, Kind};
use super::stats::t_to_normal;
pub use super::stats::{normal_quantile, t_quantile};

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
/// below it Student's t is so wide (14 sigma at 2 degrees of freedom and
/// 8 gated KPIs, 4.3 at 6) that a third baseline run would make the gate
/// blind to a change the traces show; the traces are used instead.
pub const MIN_REPEAT_DF: usize = 6;

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

/// Gated KPIs by where their sigma came from ([`Comparison::noise_counts`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NoiseCounts {
    /// From the spread over repeated runs.
    pub repeats: usize,
    /// From the runs' traces, noisy.
    pub trace: usize,
    /// From the traces of runs without noise: sigma 0.
    pub noiseless: usize,
    /// Unknown: a trace was unreadable.
    pub unknown: usize,
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
        comparison::delta(self.a, self.b)
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

    /// How many gated KPIs took their sigma from each source: repeats,
    /// the traces (noisy), the traces of noiseless runs (sigma 0), or
    /// none (a trace was unreadable).
    pub fn noise_counts(&self) -> NoiseCounts {
        let mut n = NoiseCounts::default();
        for k in self.kpis.iter().filter(|k| k.worse != 0) {
            match (k.source, k.sigma) {
                (Source::Repeats(..), _) => n.repeats += 1,
                (Source::Trace, Some(s)) if s > 0.0 => n.trace += 1,
                (Source::Trace, _) => n.noiseless += 1,
                (Source::Unknown, _) => n.unknown += 1,
            }
        }
        n
    }

    /// The repeats in words: the runs (`18 other runs of this test on
    /// this device and firmware`, or `2 other runs like A, 3 like B`) and
    /// the degrees of freedom of the KPIs that used them (`17`, `12 to 17`).
    pub fn repeats_in_words(&self) -> (String, String) {
        let (_, lo, hi) = self.from_repeats();
        let runs = if self.one_group {
            format!(
                "{} other runs of this test on this device and firmware",
                self.repeats.0
            )
        } else {
            format!(
                "{} other runs like A, {} like B",
                self.repeats.0, self.repeats.1
            )
        };
        let df = if lo == hi {
            lo.to_string()
        } else {
            format!("{lo} to {hi}")
        };
        (runs, df)
    }

    /// The runs may be compared (the same test, or differences accepted)
    /// and share a gated KPI.
    pub fn is_comparable(&self) -> bool {
        !matches!(self.comparability, Comparability::Not { .. })
    }
}

/// Relative tolerance under which two case conditions are the same.
const SAME_CONDITION: f64 = 1e-9;

/// A recorded run's cases, for the comparison engine: in plan order.
impl Cases for RunData {
    type Case = CaseData;
    fn each(&self, f: &mut dyn FnMut(&str, &CaseData)) {
        for id in &self.order {
            if let Some(c) = self.cases.get(id) {
                f(id, c);
            }
        }
    }
    fn verdict<'c>(&self, case: &'c CaseData) -> &'c str {
        &case.verdict
    }
}

impl Lookup for RunData {
    fn get(&self, id: &str) -> Option<&CaseData> {
        self.cases.get(id)
    }
}

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
    let mut unmatched = Vec::new();
    let mut matched = 0usize;
    let flips = comparison::pair(a, b, Lead::A, same_conditions, |p| match p {
        Pair::Matched { id, lead, other } => {
            matched += 1;
            case_kpis(id, lead, other, repeats, opts, &mut kpis, &mut spreads);
        }
        Pair::Differs(id) => unmatched.push(format!("{id} (its conditions differ)")),
        Pair::OnlyLead(id) | Pair::OnlyOther(id) => unmatched.push(id.to_string()),
    });
    // The causes are settled below, once the regressions are known.
    let mut flips: Vec<Flip> = flips
        .into_iter()
        .map(|f| Flip {
            case: f.case,
            from: f.from,
            to: f.to,
            cause: FlipCause::WithinNoise,
        })
        .collect();
    let excess = tails_by_metric(&kpis, &spreads);
    for (kpi, sp) in kpis.iter_mut().zip(&spreads) {
        if let Some(sp) = sp {
            let tails = excess.get(kpi.metric.as_str()).copied().unwrap_or(0.0);
            kpi.source = Source::Repeats(effective_df(sp.df, sp.residuals.len(), tails), tails);
        }
    }
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

/// The KPIs of case `id` in both runs (`ca` in A, `cb` in B), each with
/// its sigma, floor and direction, and its repeats' spread (for the tails).
fn case_kpis(
    id: &str,
    ca: &CaseData,
    cb: &CaseData,
    repeats: &Repeats,
    opts: &GateOptions,
    kpis: &mut Vec<Kpi>,
    spreads: &mut Vec<Option<Spread>>,
) {
    // A case judged in neither run (outside the mitigation range, or
    // informative) has checks for information only: nothing to gate.
    let judged = ca.verdict != "info" || cb.verdict != "info";
    for (roi, ra) in &ca.rois {
        let Some(rb) = cb.rois.get(roi) else { continue };
        for (metric, va) in &ra.metrics {
            let Some(vb) = rb.metrics.get(metric) else {
                continue;
            };
            let key = (id.to_string(), roi.clone(), metric.clone());
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
                case: id.to_string(),
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
            let rounding = NUMERIC_FLOOR * a.abs().max(b.abs()).max(1.0);
            let tolerance = Tolerance {
                floor: kpi.floor,
                noise: kpi.k * kpi.sigma.unwrap_or(0.0) + rounding,
            };
            tolerance.exceeded(Direction::of_sign(kpi.worse), a, b)
        }
        // Unbounded towards worse in B, not in A.
        (a, Some(b)) if b.is_infinite() => {
            b * f64::from(kpi.worse) > 0.0 && a.is_none_or(|a| a != b)
        }
        (Some(a), None) if a.is_finite() => fails_in_b(),
        _ => false,
    }
}

#[cfg(test)]
mod tests;
