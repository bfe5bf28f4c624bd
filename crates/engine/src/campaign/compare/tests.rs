use super::*;
use crate::campaign::noise::{frame_noise, sigma_of};
use crate::campaign::query::{CheckData, RoiData};

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
