//! Comparing two recorded runs: every KPI's change per case and ROI, the
//! verdict flips, and the noise-aware regression gate (docs/campaigns.md,
//! "The regression gate").
//!
//! A KPI's uncertainty comes from its ROI's frame-to-frame noise
//! ([`super::noise`]), propagated through the KPI's formula from the
//! levels it is computed from. A change counts as a regression when it
//! goes the way the KPI's check calls worse, by more than `k` standard
//! deviations of the difference, with `k` chosen so that the chance of
//! any false alarm over all KPIs compared is at most `alpha / 2`
//! (Bonferroni). A change too small to show in one case but shared by
//! many (a camera change moves every case) is caught by pooling each
//! metric's changes over the cases (Stouffer's method), with the other
//! half of `alpha`.

use std::collections::BTreeSet;

use super::query::{CaseData, RoiData, RunData, RunRow};

/// Chance of a false alarm over a whole comparison, when nothing changed.
pub const ALPHA: f64 = 0.05;

/// Repeated runs of A's plan on its device and firmware from which a
/// KPI's sigma is their spread rather than the noise of the trace: below
/// this the sample standard deviation is too uncertain (with 10 runs it
/// is within about 25 % of the true one, two times in three).
pub const MIN_REPEATS: usize = 10;

/// Smallest change that counts at all, relative to the KPI's size (at
/// least 1): below it two runs differ only by floating-point rounding.
const NUMERIC_FLOOR: f64 = 1e-9;

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
    /// Standard deviation of `b - a` from the two runs' noise; `None`
    /// when a run's trace gave no noise estimate (then taken as 0).
    pub sigma: Option<f64>,
    /// `+1`: a rise is worse (a `<=` check), `-1`: a fall is worse (`>=`);
    /// 0: no check judges this KPI, so it is reported, not gated.
    pub worse: i8,
    /// The change beyond the gate, in the worse direction.
    pub regressed: bool,
}

impl Kpi {
    /// `b - a`, when both are defined.
    pub fn delta(&self) -> Option<f64> {
        Some(self.b? - self.a?)
    }

    /// The change in standard deviations of the difference (signed, worse
    /// positive); `None` without both values or without noise.
    pub fn z(&self) -> Option<f64> {
        let s = self.sigma.filter(|s| *s > 0.0)?;
        Some(self.delta()? * f64::from(self.worse) / s)
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
}

/// The whole comparison.
#[derive(Debug, Clone)]
pub struct Comparison {
    /// Run A (the baseline) and run B.
    pub a: RunRow,
    /// See `a`.
    pub b: RunRow,
    /// Gate threshold of one KPI in standard deviations.
    pub k: f64,
    /// Per metric gated with noise in more than one case: the pooled
    /// (Stouffer) score of its changes towards worse, `sum(z) / sqrt(n)`,
    /// and `n`; a score above `k_pooled` is a systematic regression.
    pub pooled: Vec<(String, f64, usize)>,
    /// Gate threshold of a pooled score.
    pub k_pooled: f64,
    /// Every KPI in both runs, in A's case order.
    pub kpis: Vec<Kpi>,
    /// Verdict flips, in A's case order.
    pub flips: Vec<Flip>,
    /// Cases in only one of the runs.
    pub unmatched: Vec<String>,
    /// KPIs whose sigma is their spread over repeated runs of A's device
    /// and firmware, and the most runs one had.
    pub from_repeats: (usize, usize),
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
}

/// Compares run B with the baseline A at false-alarm rate `alpha`.
pub fn compare(a: &RunData, b: &RunData, alpha: f64) -> Comparison {
    let mut kpis = Vec::new();
    let mut flips = Vec::new();
    let mut unmatched = Vec::new();
    let mut from_repeats = (0, 0);
    for id in &a.order {
        let (Some(ca), Some(cb)) = (a.cases.get(id), b.cases.get(id)) else {
            unmatched.push(id.clone());
            continue;
        };
        if ca.verdict != cb.verdict {
            flips.push(Flip {
                case: id.clone(),
                from: ca.verdict.clone(),
                to: cb.verdict.clone(),
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
                let sigma = match (
                    a.repeats.get(&key),
                    sigma_of(metric, ra, *va),
                    sigma_of(metric, rb, *vb),
                ) {
                    // The spread over repeated runs of A's device and
                    // firmware, when there are enough: the run-to-run
                    // variation itself, each run as noisy as a repeat.
                    (Some((n, sd)), _, _) if *n >= MIN_REPEATS => {
                        from_repeats = (from_repeats.0 + 1, from_repeats.1.max(*n));
                        Some(sd * std::f64::consts::SQRT_2)
                    }
                    (_, Some(x), Some(y)) => Some(x.hypot(y)),
                    _ => None,
                };
                kpis.push(Kpi {
                    case: id.clone(),
                    roi: roi.clone(),
                    metric: metric.clone(),
                    a: *va,
                    b: *vb,
                    sigma,
                    worse: if judged {
                        worse_direction(ca, roi, metric)
                    } else {
                        0
                    },
                    regressed: false,
                });
            }
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
    let k = normal_quantile(1.0 - alpha / 2.0 / gated as f64);
    let pooled = pooled_scores(&kpis);
    let k_pooled = normal_quantile(1.0 - alpha / 2.0 / pooled.len().max(1) as f64);
    for kpi in &mut kpis {
        let shifted = pooled
            .iter()
            .any(|(m, score, _)| *m == kpi.metric && *score > k_pooled);
        kpi.regressed = regressed(kpi, k, b.cases.get(&kpi.case))
            || (shifted && kpi.z().is_some_and(|z| z > SYSTEMATIC_Z));
    }
    Comparison {
        a: a.run.clone(),
        b: b.run.clone(),
        k,
        pooled,
        k_pooled,
        kpis,
        flips,
        unmatched,
        from_repeats,
    }
}

/// In a metric that regressed as a whole (its pooled score beyond the
/// gate), a case is named when its own change towards worse is beyond
/// this many standard deviations.
const SYSTEMATIC_Z: f64 = 1.0;

/// Per metric gated with noise in at least two cases: the Stouffer score
/// `sum(z) / sqrt(n)` of its cases' changes (each `z` a standard normal
/// when nothing changed, the cases' noise independent), in name order.
fn pooled_scores(kpis: &[Kpi]) -> Vec<(String, f64, usize)> {
    let mut by: std::collections::BTreeMap<&str, (f64, usize)> = Default::default();
    for (metric, z) in kpis
        .iter()
        .filter(|k| k.worse != 0)
        .filter_map(|k| Some((k.metric.as_str(), k.z()?)))
    {
        let e = by.entry(metric).or_default();
        e.0 += z;
        e.1 += 1;
    }
    by.into_iter()
        .filter(|(_, (_, n))| *n >= 2)
        .map(|(m, (sum, n))| (m.to_string(), sum / (n as f64).sqrt(), n))
        .collect()
}

/// The gate for one KPI at `k` standard deviations; a value lost in B
/// (undefined, or unbounded) whose check fails there is a regression too.
fn regressed(kpi: &Kpi, k: f64, case_b: Option<&CaseData>) -> bool {
    if kpi.worse == 0 {
        return false;
    }
    match (kpi.a, kpi.b) {
        (Some(a), Some(b)) => {
            let change = (b - a) * f64::from(kpi.worse);
            let floor = NUMERIC_FLOOR * a.abs().max(b.abs()).max(1.0);
            change > k * kpi.sigma.unwrap_or(0.0) + floor
        }
        (Some(_), None) => case_b.is_some_and(|c| {
            c.checks
                .iter()
                .any(|x| x.roi == kpi.roi && x.metric == kpi.metric && !x.pass)
        }),
        _ => false,
    }
}

/// Which way the case's checks call worse for this KPI: a `<=` limit
/// makes a rise worse, a `>=` limit a fall.
fn worse_direction(case: &CaseData, roi: &str, metric: &str) -> i8 {
    case.checks
        .iter()
        .find(|c| c.roi == roi && c.metric == metric)
        .map_or(0, |c| if c.comparison == "<=" { 1 } else { -1 })
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

    fn run(id: i64, fdi: &[f64]) -> RunData {
        let row = RunRow {
            id,
            recorded_unix_s: 0,
            source: "plan".into(),
            date: String::new(),
            plan_id: "p".into(),
            plan_title: String::new(),
            plan_hash: String::new(),
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
        };
        let mut cases = std::collections::BTreeMap::new();
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
                pass: true,
            };
            let id = format!("c{i}");
            order.push(id.clone());
            cases.insert(
                id,
                CaseData {
                    verdict: "pass".into(),
                    rois: [("led".to_string(), roi)].into(),
                    checks: vec![check],
                    ..Default::default()
                },
            );
        }
        RunData {
            run: row,
            order,
            cases,
            repeats: Default::default(),
        }
    }

    #[test]
    fn one_sigma_in_every_case_is_a_systematic_regression_and_in_one_case_is_noise() {
        let sigma_delta = 0.0447_f64.hypot(0.0447);
        let a = run(1, &[1.0; 16]);
        let same = compare(&a, &a, ALPHA);
        assert!(same.regressed_cases().is_empty());
        assert_eq!(same.pooled, vec![("fdi_2018".to_string(), 0.0, 16)]);
        // Every case 1.2 sd worse: no single case beyond k (3.0 for 16
        // KPIs), the pooled score 1.2 x 4 = 4.8 beyond 1.96.
        let b = run(2, &[1.0 - 1.2 * sigma_delta; 16]);
        let c = compare(&a, &b, ALPHA);
        assert!(c.k > 2.9 && c.k < 3.1, "{}", c.k);
        assert!((c.k_pooled - 1.959_964).abs() < 1e-5);
        assert!((c.pooled[0].1 - 4.8).abs() < 0.01, "{:?}", c.pooled);
        assert_eq!(c.regressed_cases().len(), 16);
        // One case 1.2 sd worse: noise.
        let mut one = vec![1.0; 16];
        one[3] -= 1.2 * sigma_delta;
        assert!(
            compare(&a, &run(3, &one), ALPHA)
                .regressed_cases()
                .is_empty()
        );
        // One case 4 sd worse: that case alone; the same change for the
        // better is no regression.
        one[3] = 1.0 - 4.0 * sigma_delta;
        assert_eq!(compare(&a, &run(4, &one), ALPHA).regressed_cases(), ["c3"]);
        one[3] = 1.0 + 4.0 * sigma_delta;
        assert!(
            compare(&a, &run(5, &one), ALPHA)
                .regressed_cases()
                .is_empty()
        );
    }

    #[test]
    fn enough_repeated_runs_give_the_sigma_and_too_few_leave_the_traces() {
        // The trace gives the change a sigma of 0.063; ten repeats of A
        // spread by 0.01 give 0.0141.
        let a = |n: usize| {
            let mut a = run(1, &[1.0; 4]);
            for c in &a.order {
                let key = (c.clone(), "led".to_string(), "fdi_2018".to_string());
                a.repeats.insert(key, (n, 0.01));
            }
            a
        };
        let mut worse = vec![1.0; 4];
        worse[2] = 1.0 - 0.05;
        let b = run(2, &worse);
        let c = compare(&a(MIN_REPEATS), &b, ALPHA);
        assert_eq!(c.from_repeats, (4, MIN_REPEATS));
        let sigma = c.kpis[2].sigma.unwrap();
        assert!((sigma - 0.01 * 2f64.sqrt()).abs() < 1e-12, "{sigma}");
        assert_eq!(c.regressed_cases(), ["c2"]);
        let c = compare(&a(MIN_REPEATS - 1), &b, ALPHA);
        assert_eq!(c.from_repeats, (0, 0));
        assert!((c.kpis[2].sigma.unwrap() - 0.0632).abs() < 1e-3);
        assert!(c.regressed_cases().is_empty());
    }
}
