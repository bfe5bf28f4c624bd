//! What a run was: its plan's settings, device and inputs as flat
//! `key = value` pairs, recorded with the run so that `compare` can say
//! what differs between two runs before it compares a single KPI
//! (docs/campaigns.md, "Like with like").
//!
//! The pairs are read from the run's results (what was run, defaults
//! applied), not from the plan's text, so that an imported report gives
//! the same keys as a run recorded here. Keys are named as the plan names
//! them (`thresholds.fdi-2018-min`, `dut.camera.exposure-ms`), and each
//! belongs to one of three kinds: the test, the device, or the run.

use std::collections::BTreeMap;

use serde::Serialize;
use serde_json::Value;

use ledflicker_core::model::Results;

/// A run's set-up: key -> value, in key order.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(transparent)]
pub struct Setup(pub BTreeMap<String, String>);

/// What a key says about a run, and so what a difference in it means.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Kind {
    /// How the camera was tested: limits, sequence, grid, light levels,
    /// ROIs, KPI settings, backend. A difference makes the runs
    /// different tests: `compare` refuses them unless told to accept it.
    Test,
    /// What was tested: the `[dut]` fields, the simulated camera, the
    /// captured files. A difference is what `compare` is for.
    Device,
    /// Neither: the seed, the tool's version, the plan's id. Listed only.
    Run,
}

impl Kind {
    /// The word used in messages and reports.
    pub fn as_str(self) -> &'static str {
        match self {
            Kind::Test => "test",
            Kind::Device => "device",
            Kind::Run => "run",
        }
    }
}

/// The kind of a set-up key.
pub fn kind(key: &str) -> Kind {
    if key == "dut.backend" {
        Kind::Test
    } else if key.starts_with("dut.") || key.starts_with("input.") {
        Kind::Device
    } else if key.starts_with("plan.") || key.starts_with("tool.") {
        Kind::Run
    } else {
        Kind::Test
    }
}

/// One key whose value differs between A and B (`None`: absent).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Difference {
    /// The key, as the plan names it.
    pub key: String,
    /// `test`, `device` or `run`.
    pub kind: &'static str,
    /// Its value in A.
    pub a: Option<String>,
    /// Its value in B.
    pub b: Option<String>,
}

impl Difference {
    /// The values in A and in B as shown, `(absent)` where a run lacks
    /// the key.
    pub fn shown(&self) -> (String, String) {
        let v = |x: &Option<String>| x.clone().unwrap_or_else(|| "(absent)".to_string());
        (v(&self.a), v(&self.b))
    }
}

impl std::fmt::Display for Difference {
    /// `kind key: a -> b`, as the terminal and JUnit list it.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (a, b) = self.shown();
        write!(f, "{} {}: {a} -> {b}", self.kind, self.key)
    }
}

/// What a set-up takes of one case: its conditions and its ROIs, each
/// (name, description, whether the description is the drawn rectangle,
/// which wins over a kind alone).
#[derive(Debug, Clone, Default)]
pub struct CaseFacts {
    /// Illuminance, lux.
    pub light_lux: f64,
    /// PWM frequency, Hz.
    pub frequency_hz: f64,
    /// Duty cycle.
    pub duty: f64,
    /// The case's ROIs.
    pub rois: Vec<(String, String, bool)>,
}

impl CaseFacts {
    /// The facts of case `c`.
    pub fn of(c: &ledflicker_core::model::CaseInfo) -> CaseFacts {
        let mut rois: Vec<(String, String, bool)> = c
            .rois
            .iter()
            .map(|r| (r.name.clone(), kind_word(&json(&r.kind)), false))
            .collect();
        if let Some(f) = &c.sample_frame {
            rois.extend(f.rois.iter().map(|b| {
                let [x, y, w, h] = b.rect_px;
                let what = format!(
                    "{} at x {x}, y {y}, {w} x {h} px",
                    kind_word(&json(&b.kind))
                );
                (b.name.clone(), what, true)
            }));
        }
        CaseFacts {
            light_lux: c.light_lux,
            frequency_hz: c.frequency_hz,
            duty: c.duty,
            rois,
        }
    }
}

impl Setup {
    /// The set-up of a run's results.
    pub fn of(r: &Results) -> Setup {
        Setup::of_facts(r, r.cases.iter().map(|c| CaseFacts::of(&c)))
    }

    /// The set-up of a run's results, its cases' facts taken already
    /// (`record` takes them in the pass that reads the traces, so that a
    /// large run's spilled cases are not read twice).
    pub fn of_facts(r: &Results, cases: impl IntoIterator<Item = CaseFacts>) -> Setup {
        let mut map = BTreeMap::new();
        let mut put = |key: String, value: String| {
            map.insert(key, value);
        };
        put("plan.id".into(), r.plan.id.clone());
        put("plan.seed".into(), r.plan.seed.to_string());
        put("tool.version".into(), r.tool.version.clone());
        flatten("dut", &json(&r.dut), &mut put);
        flatten("sequence", &json(&r.sequence), &mut put);
        flatten("thresholds", &json(&r.thresholds), &mut put);
        flatten("p2020", &json(&r.p2020), &mut put);
        if let Some(d) = &r.display {
            flatten("display", &json(d), &mut put);
        }
        // The grid and the light levels as run: the cases' conditions.
        let mut lux = Vec::new();
        let mut hz = Vec::new();
        let mut duty = Vec::new();
        let mut rois = BTreeMap::new();
        for c in cases {
            lux.push(c.light_lux);
            hz.push(c.frequency_hz);
            duty.push(c.duty);
            for (name, what, drawn) in c.rois {
                if drawn {
                    rois.insert(name, what);
                } else {
                    rois.entry(name).or_insert(what);
                }
            }
        }
        put("light.levels-lux".into(), numbers(lux));
        put("grid.frequencies-hz".into(), numbers(hz));
        put("grid.duty-cycles".into(), numbers(duty));
        put("cases".into(), r.cases.len().to_string());
        for (name, what) in rois {
            put(format!("roi.{name}"), what);
        }
        // The input files but the plan (its settings are the keys above):
        // captures, camera profiles, a rig's files.
        if let Some(meta) = &r.report {
            let mut seen: BTreeMap<&str, usize> = BTreeMap::new();
            for i in meta.inputs.iter().filter(|i| i.role != "plan") {
                let n = seen.entry(i.role.as_str()).or_default();
                *n += 1;
                let name = i.path.rsplit('/').next().unwrap_or(&i.path);
                put(
                    format!("input.{}.{}", i.role, n),
                    format!("{name}, sha256 {}", i.sha256.get(..16).unwrap_or(&i.sha256)),
                );
            }
        }
        Setup(map)
    }

    /// SHA-256 of the test keys alone: runs with the same hash ran the
    /// same test, whatever their device and seed.
    pub fn test_hash(&self) -> String {
        let mut text = String::new();
        for (k, v) in self.0.iter().filter(|(k, _)| kind(k) == Kind::Test) {
            text.push_str(k);
            text.push('\0');
            text.push_str(v);
            text.push('\n');
        }
        ledflicker_core::util::sha256_hex(text.as_bytes())
    }

    /// A short label of the device as run: its firmware and the simulated
    /// camera's exposure and shutter, when there is one.
    pub fn device_label(&self) -> Option<String> {
        let get = |k: &str| self.0.get(k).filter(|v| *v != "none");
        let mut parts = Vec::new();
        if let Some(e) = get("dut.camera.exposure-ms") {
            parts.push(format!("exposure {e} ms"));
        }
        if let Some(s) = get("dut.camera.shutter") {
            parts.push(format!("{s} shutter"));
        }
        if let Some(f) = get("dut.camera.frame-rate-fps") {
            parts.push(format!("{f} fps"));
        }
        (!parts.is_empty()).then(|| parts.join(", "))
    }
}

/// The keys whose values differ between `a` and `b`, test keys first,
/// then device, then run keys, each in key order.
pub fn differences(a: &Setup, b: &Setup) -> Vec<Difference> {
    let keys: std::collections::BTreeSet<&String> = a.0.keys().chain(b.0.keys()).collect();
    let mut out: Vec<Difference> = keys
        .into_iter()
        .filter(|k| a.0.get(*k) != b.0.get(*k))
        .map(|k| Difference {
            key: k.clone(),
            kind: kind(k).as_str(),
            a: a.0.get(k).cloned(),
            b: b.0.get(k).cloned(),
        })
        .collect();
    out.sort_by_key(|d| (kind(&d.key), d.key.clone()));
    out
}

/// A serialisable part of the results as JSON (the model's types always
/// serialise; `null` stands for one that would not).
fn json<T: Serialize>(v: &T) -> Value {
    serde_json::to_value(v).unwrap_or(Value::Null)
}

fn kind_word(v: &Value) -> String {
    v.as_str().unwrap_or("roi").to_string()
}

/// The distinct values, ascending, as `[a, b, c]`.
fn numbers(mut v: Vec<f64>) -> String {
    v.sort_by(f64::total_cmp);
    v.dedup();
    let words: Vec<String> = v.iter().map(|x| number(*x)).collect();
    format!("[{}]", words.join(", "))
}

/// A number as the plan would write it: shortest round-trip form.
fn number(x: f64) -> String {
    serde_json::Number::from_f64(x).map_or_else(|| x.to_string(), |n| n.to_string())
}

/// `prefix.key = value` for each scalar leaf of `v`, the JSON names in
/// the plan's spelling (`exposure_ms` -> `exposure-ms`); arrays of
/// scalars as one value, arrays of objects by position.
fn flatten(prefix: &str, v: &Value, put: &mut dyn FnMut(String, String)) {
    match v {
        Value::Object(map) => {
            for (k, x) in map {
                flatten(&format!("{prefix}.{}", k.replace('_', "-")), x, put);
            }
        }
        Value::Array(items) if items.iter().any(|x| x.is_object() || x.is_array()) => {
            for (i, x) in items.iter().enumerate() {
                flatten(&format!("{prefix}[{}]", i + 1), x, put);
            }
        }
        Value::Array(items) => {
            let words: Vec<String> = items.iter().map(scalar).collect();
            put(prefix.to_string(), format!("[{}]", words.join(", ")));
        }
        x => put(prefix.to_string(), scalar(x)),
    }
}

fn scalar(v: &Value) -> String {
    match v {
        Value::Null => "none".to_string(),
        Value::String(s) => s.clone(),
        x => x.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn setup(pairs: &[(&str, &str)]) -> Setup {
        Setup(
            pairs
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect(),
        )
    }

    #[test]
    fn keys_are_test_device_or_run_and_differences_list_the_test_first() {
        assert_eq!(kind("thresholds.fdi-2018-min"), Kind::Test);
        assert_eq!(kind("dut.backend"), Kind::Test);
        assert_eq!(kind("dut.camera.exposure-ms"), Kind::Device);
        assert_eq!(kind("input.capture.1"), Kind::Device);
        assert_eq!(kind("plan.seed"), Kind::Run);
        let a = setup(&[
            ("plan.seed", "1"),
            ("dut.firmware", "1.0"),
            ("thresholds.fdi-2018-min", "0.1"),
        ]);
        let b = setup(&[
            ("plan.seed", "2"),
            ("dut.firmware", "1.1"),
            ("thresholds.fdi-2018-min", "1.0"),
            ("roi.led2", "led"),
        ]);
        let d = differences(&a, &b);
        let keys: Vec<&str> = d.iter().map(|d| d.key.as_str()).collect();
        assert_eq!(
            keys,
            [
                "roi.led2",
                "thresholds.fdi-2018-min",
                "dut.firmware",
                "plan.seed"
            ]
        );
        assert_eq!(d[0].a, None);
        assert!(differences(&a, &a).is_empty());
        // The test hash sees test keys only.
        let mut c = a.clone();
        c.0.insert("dut.firmware".into(), "2.0".into());
        c.0.insert("plan.seed".into(), "9".into());
        assert_eq!(a.test_hash(), c.test_hash());
        assert_ne!(a.test_hash(), b.test_hash());
    }

    #[test]
    fn nested_values_flatten_to_plan_spelled_keys() {
        let v = serde_json::json!({
            "fdi_2018_min": 0.1,
            "percent_flicker_max": null,
            "light_levels": [{"light_lux": 40.0, "fdi_2018_min": 0.05}],
            "list": [1.0, 2.5]
        });
        let mut got = BTreeMap::new();
        flatten("thresholds", &v, &mut |k, v| {
            got.insert(k, v);
        });
        assert_eq!(got["thresholds.fdi-2018-min"], "0.1");
        assert_eq!(got["thresholds.percent-flicker-max"], "none");
        assert_eq!(got["thresholds.light-levels[1].light-lux"], "40.0");
        assert_eq!(got["thresholds.list"], "[1.0, 2.5]");
        assert_eq!(numbers(vec![2.0, 0.5, 2.0]), "[0.5, 2.0]");
    }
}
