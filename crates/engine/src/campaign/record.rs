//! Recording one finished report directory: its results model and the
//! files beside it (traces, manifest) as one run, in one transaction.

use std::path::Path;

use rayon::prelude::*;

use super::setup::{CaseFacts, Setup};
use super::sql::{Query, Tx, values};
use super::{CampaignError, Database, noise};
use ledflicker_core::model::{CaseInfo, Results};

/// Which command recorded a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// `ledflicker plan`.
    Plan,
    /// `ledflicker merge`.
    Merge,
    /// `ledflicker import`.
    Import,
}

impl Source {
    /// The word the database holds.
    pub fn as_str(self) -> &'static str {
        match self {
            Source::Plan => "plan",
            Source::Merge => "merge",
            Source::Import => "import",
        }
    }
}

/// What is known of a recorded report's signature.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Signature {
    /// The report carries no signature.
    Unsigned,
    /// Signed by the run that recorded it.
    Signed,
    /// Imported, every hash and signature matched, and every signer holds
    /// a certificate that chains to one the user trusts (`--trust`), as
    /// `verify --trust` checks.
    Intact,
    /// Imported, every hash and signature matched, but no trusted
    /// certificate vouched for the signers: anyone can sign under any
    /// name, so the signature proves nothing about who signed.
    Untrusted,
    /// Imported, and a hash or signature did not match: the files may
    /// not be the ones signed.
    Broken,
    /// Imported signed by a build without the sign-off: not checked.
    Unchecked,
}

impl Signature {
    /// The word the database holds.
    pub fn as_str(self) -> &'static str {
        match self {
            Signature::Unsigned => "unsigned",
            Signature::Signed => "signed",
            Signature::Intact => "intact",
            Signature::Untrusted => "untrusted",
            Signature::Broken => "broken",
            Signature::Unchecked => "unchecked",
        }
    }
}

/// Who recorded the run and what its signature is worth.
#[derive(Debug, Clone)]
pub struct Provenance {
    /// The command.
    pub source: Source,
    /// "Name, Role" of the (first) signer, when signed.
    pub signer: Option<String>,
    /// The signature's state.
    pub signature: Signature,
}

/// A run as the database keeps it: the results and what is read beside
/// them. Built before the transaction, so that reading files never holds
/// the write lock.
struct Prepared {
    dir: String,
    /// The report's date and inputs: from the model, else from
    /// results.json (the pipeline adds them as it writes the file).
    meta: Option<ledflicker_core::model::ReportMeta>,
    results_sha256: String,
    manifest_sha256: Option<String>,
    /// Per case, per ROI (in the case's order): the trace's noise.
    noise: Vec<Vec<Option<noise::Noise>>>,
    /// What the run was: its test, device and inputs.
    setup: Setup,
}

/// Records the report directory `dir`, whose results model is `results`;
/// returns the new run's id.
pub fn record(
    db: &mut Database,
    results: &Results,
    dir: &Path,
    provenance: &Provenance,
) -> Result<i64, CampaignError> {
    let prepared = prepare(results, dir)?;
    db.write(|tx| {
        let run_id = insert_run(tx, results, &prepared, provenance)?;
        for (idx, case) in results.cases.iter().enumerate() {
            insert_case(tx, run_id, idx, &case, &prepared.noise[idx])?;
        }
        // A case that could not be read back leaves the run unrecorded.
        spill_read(results)?;
        Ok(run_id)
    })
}

/// A large run's case that could not be read back from its spill file.
fn spill_read(results: &Results) -> Result<(), CampaignError> {
    match results.cases.read_error() {
        Some(why) => Err(CampaignError::Input(why)),
        None => Ok(()),
    }
}

fn prepare(results: &Results, dir: &Path) -> Result<Prepared, CampaignError> {
    let unreadable = |what: &Path, e: std::io::Error| {
        CampaignError::Input(format!("cannot read `{}`: {e}", what.display()))
    };
    let abs = std::fs::canonicalize(dir).map_err(|e| unreadable(dir, e))?;
    let results_path = dir.join("results.json");
    let (results_sha256, stored_meta) = read_results_file(&results_path, results.report.is_none())?;
    let manifest = dir.join("manifest.txt");
    let manifest_sha256 = match ledflicker_core::util::read_input(&manifest) {
        Ok(m) => Some(ledflicker_core::util::sha256_hex(&m)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(unreadable(&manifest, e)),
    };
    // The traces are read and parsed in parallel: recording a run is on
    // the wall time of every `plan`.
    // One pass over the cases (a large run's are read back from its
    // spill file): each trace's noise, and the case's facts for the
    // set-up.
    let (noise, facts): (Vec<_>, Vec<_>) = (0..results.cases.len())
        .into_par_iter()
        .map(|i| {
            let Some(case) = results.cases.get(i) else {
                return (Vec::new(), CaseFacts::default());
            };
            let names: Vec<&str> = case.rois.iter().map(|r| r.name.as_str()).collect();
            // A trace that is gone or unreadable leaves the noise unknown:
            // `compare` then says it cannot judge that case's changes.
            let noise = match read_trace(&abs, &case.trace) {
                Ok(text) => noise::of_trace(&text, &names),
                Err(_) => vec![None; names.len()],
            };
            (noise, CaseFacts::of(&case))
        })
        .unzip();
    spill_read(results)?;
    let meta = results.report.clone().or(stored_meta);
    let mut setup = Setup::of_facts(results, facts);
    if results.report.is_none() {
        // The inputs are in the `report` object read from the file.
        let with_meta = Results {
            report: meta.clone(),
            ..results.without_cases()
        };
        let inputs = Setup::of(&with_meta);
        setup.0.extend(
            inputs
                .0
                .into_iter()
                .filter(|(k, _)| k.starts_with("input.")),
        );
    }
    Ok(Prepared {
        setup,
        dir: abs.to_string_lossy().into_owned(),
        meta,
        results_sha256,
        manifest_sha256,
        noise,
    })
}

/// The largest trace read for its noise: a trace of a case of a minute at
/// 240 fps with a dozen ROIs is a few MB.
const MAX_TRACE_BYTES: u64 = 256 << 20;

/// The trace `rel` (as results.json names it) of the report directory
/// `dir` (absolute, links resolved): only a relative path of plain names
/// that stays inside the directory, only a regular file (never a FIFO or
/// a device, which would hang or never end), at most
/// [`MAX_TRACE_BYTES`]. A report directory is input: its results.json
/// may name anything.
fn read_trace(dir: &Path, rel: &str) -> std::io::Result<String> {
    use std::io::Read;
    use std::path::Component;
    let refuse = |why: &str| std::io::Error::new(std::io::ErrorKind::InvalidInput, why.to_string());
    let path = Path::new(rel);
    if rel.is_empty() || !path.components().all(|c| matches!(c, Component::Normal(_))) {
        return Err(refuse(
            "a trace path must be relative, inside the report directory",
        ));
    }
    let full = std::fs::canonicalize(dir.join(path))?;
    if !full.starts_with(dir) {
        return Err(refuse("the trace leads out of the report directory"));
    }
    let mut text = String::new();
    ledflicker_core::util::open_input(&full)?
        .take(MAX_TRACE_BYTES)
        .read_to_string(&mut text)?;
    Ok(text)
}

/// Reads results.json once, as a stream: its SHA-256 and, when `want_meta`,
/// its `report` object. A large run's results.json is hundreds of MB, so
/// it is never held whole: that would add its size to the run's peak
/// memory after the report is written.
fn read_results_file(
    path: &Path,
    want_meta: bool,
) -> Result<(String, Option<ledflicker_core::model::ReportMeta>), CampaignError> {
    use sha2::Digest;
    use std::io::Read;

    /// Hashes what is read through it.
    struct Hashing<R> {
        inner: R,
        hasher: sha2::Sha256,
    }
    impl<R: Read> Read for Hashing<R> {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            let n = self.inner.read(buf)?;
            self.hasher.update(&buf[..n]);
            Ok(n)
        }
    }
    #[derive(serde::Deserialize)]
    struct Head {
        report: Option<ledflicker_core::model::ReportMeta>,
    }

    let unreadable =
        |e: std::io::Error| CampaignError::Input(format!("cannot read `{}`: {e}", path.display()));
    let file = ledflicker_core::util::open_input(path).map_err(unreadable)?;
    let mut reader = Hashing {
        inner: std::io::BufReader::new(file),
        hasher: sha2::Sha256::new(),
    };
    let meta = match want_meta {
        true => {
            serde_json::from_reader::<_, Head>(&mut reader)
                .map_err(|e| CampaignError::Input(format!("`{}`: {e}", path.display())))?
                .report
        }
        false => None,
    };
    // The rest (all of it when the `report` object was not wanted) goes
    // into the hash only.
    std::io::copy(&mut reader, &mut std::io::sink()).map_err(unreadable)?;
    Ok((ledflicker_core::util::hex(&reader.hasher.finalize()), meta))
}

fn insert_run(
    tx: &Tx<'_>,
    r: &Results,
    p: &Prepared,
    provenance: &Provenance,
) -> Result<i64, CampaignError> {
    let date = p.meta.as_ref().map_or("", |m| m.date.as_str());
    let plan_hash = p
        .meta
        .as_ref()
        .map(|m| crate::shard::record::plan_hash(&m.inputs))
        .unwrap_or_default();
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs() as i64);
    let setup = &p.setup;
    let setup_json =
        serde_json::to_string(setup).map_err(|e| CampaignError::Input(e.to_string()))?;
    let id = tx.query_row(
        "INSERT INTO runs (recorded_unix_s, source, date, plan_id, plan_title, plan_hash, seed, \
         tool, backend, supplier, model, serial, firmware, signer, signature, report_dir, \
         results_sha256, manifest_sha256, verdict, cases_total, cases_pass, cases_fail, cases_info, \
         setup, test_hash) \
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17, ?18, \
         ?19, ?20, ?21, ?22, ?23, ?24, ?25) RETURNING id",
        &values![
            now,
            provenance.source.as_str(),
            date,
            r.plan.id,
            r.plan.title,
            plan_hash,
            // SQLite integers are signed: a seed above 2^63 keeps its bits.
            r.plan.seed as i64,
            format!("{} {}", r.tool.name, r.tool.version),
            r.dut.backend,
            r.dut.supplier,
            r.dut.model,
            r.dut.serial,
            r.dut.firmware,
            provenance.signer,
            provenance.signature.as_str(),
            p.dir,
            p.results_sha256,
            p.manifest_sha256,
            r.verdict.as_str(),
            r.counts.total as i64,
            r.counts.pass as i64,
            r.counts.fail as i64,
            r.counts.info as i64,
            setup_json,
            setup.test_hash(),
        ],
        |row| row.get::<i64>("id"),
    )?;
    id.ok_or_else(|| CampaignError::Unusable {
        path: tx.path().to_path_buf(),
        message: "the new run got no id".to_string(),
    })
}

fn insert_case(
    tx: &Tx<'_>,
    run_id: i64,
    idx: usize,
    c: &CaseInfo,
    noise: &[Option<noise::Noise>],
) -> Result<(), CampaignError> {
    let idx = idx as i64;
    tx.execute(
        "INSERT INTO cases (run_id, idx, id, light_lux, frequency_hz, duty, verdict, not_judged, trace) \
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)",
        &values![
        run_id,
        idx,
        c.id,
        c.light_lux,
        c.frequency_hz,
        c.duty,
        c.verdict.as_str(),
        c.not_judged,
        c.trace
    ],
    )?;
    let roi_row = "INSERT INTO rois (run_id, idx, roi, kind, saturated, level_off, level_on, level_min, \
         level_max, noise_on_dn, noise_off_dn, off_frames) \
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12)";
    let metric_row =
        "INSERT INTO metrics (run_id, idx, roi, metric, value) VALUES (?1, ?2, ?3, ?4, ?5)";
    for (roi, n) in c.rois.iter().zip(noise) {
        let kind = match roi.kind {
            ledflicker_core::model::RoiKind::Led => "led",
            ledflicker_core::model::RoiKind::Background => "background",
        };
        tx.execute(
            roi_row,
            &values![
                run_id,
                idx,
                roi.name,
                kind,
                roi.saturated,
                roi.levels.off,
                roi.levels.on,
                roi.levels.min,
                roi.levels.max,
                n.and_then(|n| n.on_dn),
                n.and_then(|n| n.off_dn),
                n.map_or(0, |n| n.off_frames) as i64,
            ],
        )?;
        for (metric, value) in &roi.metrics {
            tx.execute(metric_row, &values![run_id, idx, roi.name, metric, value])?;
        }
    }
    let check_row = "INSERT INTO checks (run_id, idx, roi, metric, comparison, threshold, value, unbounded, pass) \
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)";
    for k in &c.checks {
        tx.execute(
            check_row,
            &values![
                run_id,
                idx,
                k.roi,
                k.metric,
                k.comparison.as_str(),
                k.threshold,
                k.value,
                k.unbounded,
                k.pass
            ],
        )?;
    }
    Ok(())
}
