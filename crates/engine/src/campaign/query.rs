//! Reading runs back: the list `history` prints, and one run whole for
//! `compare`.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Serialize;

use super::repeats::{Key, Repeats};
use super::setup::Setup;
use super::sql::{Mismatch, Query, Row, Value, values};
use super::{CampaignError, Database};

/// One recorded run, as `history` lists it (`--json`: these fields).
#[derive(Debug, Clone, Serialize)]
pub struct RunRow {
    /// The run's id, for `compare`.
    pub id: i64,
    /// When it was recorded, Unix seconds.
    pub recorded_unix_s: i64,
    /// `plan`, `merge` or `import`.
    pub source: String,
    /// The report date, `YYYY-MM-DD`.
    pub date: String,
    /// Plan id.
    pub plan_id: String,
    /// Plan title.
    pub plan_title: String,
    /// Hash of the plan and its inputs.
    pub plan_hash: String,
    /// The plan's seed (all 64 bits).
    pub seed: u64,
    /// `ledflicker <version>`.
    pub tool: String,
    /// Backend id.
    pub backend: String,
    /// `[dut] supplier`.
    pub supplier: String,
    /// `[dut] model`: the camera.
    pub model: String,
    /// `[dut] serial`.
    pub serial: String,
    /// `[dut] firmware`.
    pub firmware: String,
    /// Signer, "Name, Role", when signed.
    pub signer: Option<String>,
    /// `unsigned`, `signed`, `intact`, `broken` or `unchecked`.
    pub signature: String,
    /// The report directory, absolute.
    pub report_dir: String,
    /// SHA-256 of its results.json.
    pub results_sha256: String,
    /// SHA-256 of its manifest.txt, when signed.
    pub manifest_sha256: Option<String>,
    /// `pass`, `fail` or `info`.
    pub verdict: String,
    /// Cases, and how many passed, failed and were not judged.
    pub cases: [i64; 4],
    /// What the run was (docs/campaigns.md, "Like with like"); `None` for
    /// a run recorded before the database kept it.
    pub setup: Option<Setup>,
    /// SHA-256 of the set-up's test keys; `None` as `setup`.
    pub test_hash: Option<String>,
}

const RUN_COLUMNS: &str = "id, recorded_unix_s, source, date, plan_id, plan_hash, tool, backend, \
    supplier, model, serial, firmware, signer, signature, report_dir, results_sha256, \
    manifest_sha256, verdict, cases_total, cases_pass, cases_fail, cases_info, plan_title, seed, \
    setup, test_hash";

fn run_row(r: &Row) -> Result<RunRow, Mismatch> {
    Ok(RunRow {
        id: r.get("id")?,
        recorded_unix_s: r.get("recorded_unix_s")?,
        source: r.get("source")?,
        date: r.get("date")?,
        plan_id: r.get("plan_id")?,
        plan_hash: r.get("plan_hash")?,
        tool: r.get("tool")?,
        backend: r.get("backend")?,
        supplier: r.get("supplier")?,
        model: r.get("model")?,
        serial: r.get("serial")?,
        firmware: r.get("firmware")?,
        signer: r.get("signer")?,
        signature: r.get("signature")?,
        report_dir: r.get("report_dir")?,
        results_sha256: r.get("results_sha256")?,
        manifest_sha256: r.get("manifest_sha256")?,
        verdict: r.get("verdict")?,
        cases: [
            r.get("cases_total")?,
            r.get("cases_pass")?,
            r.get("cases_fail")?,
            r.get("cases_info")?,
        ],
        plan_title: r.get("plan_title")?,
        // Stored as SQL's signed integer, bit for bit.
        seed: r.get::<i64>("seed")? as u64,
        setup: r
            .get::<Option<String>>("setup")?
            .and_then(|s| serde_json::from_str(&s).ok()),
        test_hash: r.get("test_hash")?,
    })
}

/// Which runs to list; every field set must match (exactly; dates
/// inclusive).
#[derive(Debug, Clone, Default)]
pub struct Filter {
    /// `[dut] model`.
    pub camera: Option<String>,
    /// `[dut] serial`.
    pub serial: Option<String>,
    /// `[dut] firmware`.
    pub firmware: Option<String>,
    /// Plan id.
    pub plan: Option<String>,
    /// Report date on or after, `YYYY-MM-DD`.
    pub since: Option<String>,
    /// Report date on or before, `YYYY-MM-DD`.
    pub until: Option<String>,
    /// `pass`, `fail` or `info`.
    pub verdict: Option<String>,
}

impl Filter {
    /// The SQL `WHERE` clause and its values, the columns of `runs`
    /// qualified by `prefix` (e.g. `r.`).
    fn clause(&self, prefix: &str) -> (String, Vec<String>) {
        let mut terms = Vec::new();
        let mut values = Vec::new();
        for (column, op, value) in [
            ("model", "=", &self.camera),
            ("serial", "=", &self.serial),
            ("firmware", "=", &self.firmware),
            ("plan_id", "=", &self.plan),
            ("date", ">=", &self.since),
            ("date", "<=", &self.until),
            ("verdict", "=", &self.verdict),
        ] {
            if let Some(v) = value {
                values.push(v.clone());
                terms.push(format!("{prefix}{column} {op} ?{}", values.len()));
            }
        }
        let clause = if terms.is_empty() {
            String::new()
        } else {
            format!(" WHERE {}", terms.join(" AND "))
        };
        (clause, values)
    }
}

/// The runs `filter` selects, oldest first.
pub fn history(db: &Database, filter: &Filter) -> Result<Vec<RunRow>, CampaignError> {
    let (clause, values) = filter.clause("");
    db.query_map(
        &format!("SELECT {RUN_COLUMNS} FROM runs{clause} ORDER BY id"),
        &texts(values),
        run_row,
    )
}

fn texts(values: Vec<String>) -> Vec<Value> {
    values.into_iter().map(Value::Text).collect()
}

/// One value of a KPI in a run: a point of `ledflicker trend`.
#[derive(Debug, Clone, Serialize)]
pub struct TrendPoint {
    /// Run id.
    pub run: i64,
    /// Report date, `YYYY-MM-DD`.
    pub date: String,
    /// Plan id.
    pub plan: String,
    /// `[dut] model`, serial and firmware.
    pub camera: String,
    /// See `camera`.
    pub serial: String,
    /// See `camera`.
    pub firmware: String,
    /// Case id.
    pub case: String,
    /// ROI name.
    pub roi: String,
    /// Metric id.
    pub metric: String,
    /// Its value; `None`: undefined in that run.
    pub value: Option<f64>,
    /// The limit it was judged against in that run (`">="` or `"<="`
    /// and the threshold); `None`: not judged.
    pub limit: Option<(String, f64)>,
}

/// Every KPI name the database holds a value of, in order: what `trend
/// --kpi` may name.
pub fn metric_names(db: &Database) -> Result<Vec<String>, CampaignError> {
    db.query_map(
        "SELECT DISTINCT metric FROM metrics ORDER BY metric",
        &[],
        |r| r.get("metric"),
    )
}

/// The values of `metric` (of case `case` and ROI `roi` when given) in the
/// runs `filter` selects, by run (oldest first) then plan order.
pub fn trend(
    db: &Database,
    filter: &Filter,
    metric: &str,
    case: Option<&str>,
    roi: Option<&str>,
) -> Result<Vec<TrendPoint>, CampaignError> {
    let (clause, mut values) = filter.clause("r.");
    let mut terms = vec![clause];
    for (column, v) in [("m.metric", Some(metric)), ("c.id", case), ("m.roi", roi)] {
        if let Some(v) = v {
            values.push(v.to_string());
            let join = if terms.concat().is_empty() {
                " WHERE"
            } else {
                " AND"
            };
            terms.push(format!("{join} {column} = ?{}", values.len()));
        }
    }
    let mut points = db.query_map(
        &format!(
            "SELECT r.id AS run_id, r.date AS date, r.plan_id AS plan_id, r.model AS model, \
             r.serial AS serial, r.firmware AS firmware, c.id AS case_id, c.idx AS idx, \
             m.roi AS roi, m.metric AS metric, m.value AS value, \
             k.comparison AS comparison, k.threshold AS threshold \
             FROM metrics m JOIN cases c ON c.run_id = m.run_id AND c.idx = m.idx \
             JOIN runs r ON r.id = m.run_id \
             LEFT JOIN checks k ON k.run_id = m.run_id AND k.idx = m.idx AND k.roi = m.roi AND k.metric = m.metric\
             {} ORDER BY r.id, c.idx, m.roi",
            terms.concat()
        ),
        &texts(values),
        |r| {
            let limit = (
                r.get::<Option<String>>("comparison")?,
                r.get::<Option<f64>>("threshold")?,
            );
            let point = TrendPoint {
                run: r.get("run_id")?,
                date: r.get("date")?,
                plan: r.get("plan_id")?,
                camera: r.get("model")?,
                serial: r.get("serial")?,
                firmware: r.get("firmware")?,
                case: r.get("case_id")?,
                roi: r.get("roi")?,
                metric: r.get("metric")?,
                value: r.get("value")?,
                limit: match limit {
                    (Some(op), Some(threshold)) => Some((op, threshold)),
                    _ => None,
                },
            };
            Ok((r.get::<i64>("idx")?, point))
        },
    )?;
    // ROI names in byte order, as SQLite sorts text: a server's collation
    // may sort them otherwise.
    points.sort_by(|(i, a), (j, b)| (a.run, i, &a.roi).cmp(&(b.run, j, &b.roi)));
    Ok(points.into_iter().map(|(_, p)| p).collect())
}

/// The run with id `id`.
pub fn run(db: &Database, id: i64) -> Result<Option<RunRow>, CampaignError> {
    db.query_row(
        &format!("SELECT {RUN_COLUMNS} FROM runs WHERE id = ?1"),
        &values![id],
        run_row,
    )
}

/// The newest run recorded of the report directory `dir`.
pub fn run_of_dir(db: &Database, dir: &Path) -> Result<Option<i64>, CampaignError> {
    let abs = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
    Ok(db
        .query_row(
            "SELECT max(id) AS id FROM runs WHERE report_dir = ?1",
            &values![abs.to_string_lossy().as_ref()],
            |r| r.get::<Option<i64>>("id"),
        )?
        .flatten())
}

/// One ROI of one case of a recorded run.
#[derive(Debug, Clone, Default)]
pub struct RoiData {
    /// `led` or `background`.
    pub kind: String,
    /// Lowest and highest PWM-segment luma, DN.
    pub level_min: f64,
    /// See `level_min`.
    pub level_max: f64,
    /// Mean luma of the OFF segment, DN.
    pub level_off: Option<f64>,
    /// Mean luma of the steady-ON segment, DN.
    pub level_on: Option<f64>,
    /// Frame-to-frame noise of an ON frame's ROI luma, DN; `None`: unknown.
    pub noise_on_dn: Option<f64>,
    /// The same of an OFF frame.
    pub noise_off_dn: Option<f64>,
    /// OFF frames, whose mean is the OFF reference.
    pub off_frames: usize,
    /// Metric -> value (`None`: undefined).
    pub metrics: BTreeMap<String, Option<f64>>,
}

/// One threshold check of a recorded case.
#[derive(Debug, Clone)]
pub struct CheckData {
    /// ROI.
    pub roi: String,
    /// Metric checked.
    pub metric: String,
    /// `>=` or `<=`.
    pub comparison: String,
    /// Threshold.
    pub threshold: f64,
    /// Whether it was met.
    pub pass: bool,
}

/// One case of a recorded run.
#[derive(Debug, Clone, Default)]
pub struct CaseData {
    /// `pass`, `fail` or `info`.
    pub verdict: String,
    /// ROI name -> its data.
    pub rois: BTreeMap<String, RoiData>,
    /// Its checks.
    pub checks: Vec<CheckData>,
    /// Its conditions: ambient lux, PWM frequency (Hz) and duty.
    pub light_lux: f64,
    /// See `light_lux`.
    pub frequency_hz: f64,
    /// See `light_lux`.
    pub duty: f64,
}

/// A recorded run whole: its row and its cases by case id (in plan order
/// by `order`).
#[derive(Debug, Clone)]
pub struct RunData {
    /// The run.
    pub run: RunRow,
    /// Case ids in plan order.
    pub order: Vec<String>,
    /// Case id -> case.
    pub cases: BTreeMap<String, CaseData>,
}

/// The repeated runs of A's test on A's device and firmware (group 0)
/// and of B's on B's (group 1; the same group when A and B are of one
/// device and firmware): runs of the same plan id, `[dut]` model, serial
/// and firmware, and the same test (set-up hash), with each KPI's
/// defined values. A and B themselves are left out, so that the spread
/// is independent of the change it judges (with A and B alone, their
/// own difference would be its measure). A run without a recorded
/// set-up has no repeats.
pub fn repeats(db: &Database, a: &RunRow, b: &RunRow) -> Result<Repeats, CampaignError> {
    let same = |x: &RunRow, y: &RunRow| {
        (&x.plan_id, &x.model, &x.serial, &x.firmware, &x.test_hash)
            == (&y.plan_id, &y.model, &y.serial, &y.firmware, &y.test_hash)
    };
    let groups: Vec<&RunRow> = if same(a, b) { vec![a] } else { vec![a, b] };
    let mut out = Repeats {
        one_group: groups.len() == 1,
        ..Repeats::default()
    };
    for (g, run) in groups.into_iter().enumerate() {
        let Some(hash) = &run.test_hash else { continue };
        let rows = db.query_map(
            "SELECT r.id AS run_id, c.id AS case_id, m.roi AS roi, m.metric AS metric, \
             m.value AS value FROM metrics m \
             JOIN cases c ON c.run_id = m.run_id AND c.idx = m.idx \
             JOIN runs r ON r.id = m.run_id \
             WHERE r.plan_id = ?1 AND r.model = ?2 AND r.serial = ?3 AND r.firmware = ?4 \
             AND r.test_hash = ?5 AND m.value IS NOT NULL",
            &values![run.plan_id, run.model, run.serial, run.firmware, hash],
            |r| {
                Ok((
                    r.get::<i64>("run_id")?,
                    (
                        r.get::<String>("case_id")?,
                        r.get::<String>("roi")?,
                        r.get::<String>("metric")?,
                    ),
                    r.get::<f64>("value")?,
                ))
            },
        )?;
        let mut by_run: BTreeMap<i64, BTreeMap<Key, f64>> = BTreeMap::new();
        for (id, key, value) in rows {
            by_run.entry(id).or_default().insert(key, value);
        }
        out.runs.extend(
            by_run
                .into_iter()
                .filter(|(id, _)| *id != a.id && *id != b.id)
                .map(|(id, values)| (g, id, values)),
        );
    }
    Ok(out)
}

/// Reads run `id` whole; an unknown id is an error naming it.
pub fn load_run(db: &Database, id: i64) -> Result<RunData, CampaignError> {
    let row = run(db, id)?.ok_or_else(|| {
        CampaignError::Input(format!(
            "no run {id} in `{}`\n    hint: `ledflicker history` lists the runs",
            db.path().display()
        ))
    })?;
    let (mut order, mut ids, mut cases) = (Vec::new(), BTreeMap::new(), BTreeMap::new());
    let rows = db.query_map(
        "SELECT idx, id, verdict, light_lux, frequency_hz, duty FROM cases WHERE run_id = ?1 \
         ORDER BY idx",
        &values![id],
        |r| {
            let head = (
                r.get::<i64>("idx")?,
                r.get::<String>("id")?,
                r.get("verdict")?,
            );
            let conditions = (r.get("light_lux")?, r.get("frequency_hz")?, r.get("duty")?);
            Ok((head, conditions))
        },
    )?;
    for ((idx, case, verdict), (light_lux, frequency_hz, duty)) in rows {
        order.push(case.clone());
        ids.insert(idx, case.clone());
        cases.insert(
            case,
            CaseData {
                verdict,
                light_lux,
                frequency_hz,
                duty,
                ..Default::default()
            },
        );
    }
    let case_of = |idx: i64| ids.get(&idx).cloned().unwrap_or_default();
    let rows = db.query_map(
        "SELECT idx, roi, kind, level_min, level_max, level_off, level_on, noise_on_dn, \
         noise_off_dn, off_frames FROM rois WHERE run_id = ?1",
        &values![id],
        |r| {
            Ok((
                r.get::<i64>("idx")?,
                r.get::<String>("roi")?,
                RoiData {
                    kind: r.get("kind")?,
                    level_min: r.get("level_min")?,
                    level_max: r.get("level_max")?,
                    level_off: r.get("level_off")?,
                    level_on: r.get("level_on")?,
                    noise_on_dn: r.get("noise_on_dn")?,
                    noise_off_dn: r.get("noise_off_dn")?,
                    off_frames: r.get::<i64>("off_frames")?.max(0) as usize,
                    metrics: BTreeMap::new(),
                },
            ))
        },
    )?;
    for (idx, roi, data) in rows {
        if let Some(c) = cases.get_mut(&case_of(idx)) {
            c.rois.insert(roi, data);
        }
    }
    let rows = db.query_map(
        "SELECT idx, roi, metric, value FROM metrics WHERE run_id = ?1",
        &values![id],
        |r| {
            Ok((
                r.get::<i64>("idx")?,
                r.get::<String>("roi")?,
                r.get::<String>("metric")?,
                r.get::<Option<f64>>("value")?,
            ))
        },
    )?;
    for (idx, roi, metric, value) in rows {
        if let Some(d) = cases
            .get_mut(&case_of(idx))
            .and_then(|c| c.rois.get_mut(&roi))
        {
            d.metrics.insert(metric, value);
        }
    }
    let mut rows = db.query_map(
        "SELECT idx, roi, metric, comparison, threshold, pass FROM checks WHERE run_id = ?1",
        &values![id],
        |r| {
            Ok((
                r.get::<i64>("idx")?,
                CheckData {
                    roi: r.get("roi")?,
                    metric: r.get("metric")?,
                    comparison: r.get("comparison")?,
                    threshold: r.get("threshold")?,
                    pass: r.get("pass")?,
                },
            ))
        },
    )?;
    // In key order, as SQLite's table holds them, with text in byte
    // order whatever a server's collation.
    rows.sort_by(|(i, a), (j, b)| {
        (i, &a.roi, &a.metric, &a.comparison).cmp(&(j, &b.roi, &b.metric, &b.comparison))
    });
    for (idx, check) in rows {
        if let Some(c) = cases.get_mut(&case_of(idx)) {
            c.checks.push(check);
        }
    }
    Ok(RunData {
        run: row,
        order,
        cases,
    })
}
