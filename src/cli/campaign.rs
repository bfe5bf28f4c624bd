//! The results database on the command line: `--db` / `--no-db` of `plan`
//! and `merge` and the recording after their report, `import` and
//! `history` (docs/campaigns.md). `compare` is [`super::compare`].

use super::output::{out, outln};
use std::path::{Path, PathBuf};

use clap::Args;

use super::{ExitCode, Failure, UsageError};
use crate::campaign::query::{self, Filter, RunRow};
use crate::campaign::record::{Provenance, Signature, Source};
use crate::campaign::{self, Database, Location};

/// `--db` and `--no-db` of `plan` and `merge`.
#[derive(Args, Debug, Clone)]
pub(super) struct RecordArgs {
    /// Results database the run is recorded in: an SQLite file, or a
    /// PostgreSQL server as postgres://USER@HOST:PORT/DATABASE (password in
    /// PGPASSFILE or ~/.pgpass) [default: $LEDFLICKER_DB, else
    /// $XDG_DATA_HOME/ledflicker/results.sqlite, else
    /// ~/.local/share/ledflicker/results.sqlite].
    #[arg(long, value_name = "PATH|URL")]
    db: Option<PathBuf>,
    /// Record the run in no results database.
    #[arg(long, conflicts_with = "db")]
    no_db: bool,
}

impl RecordArgs {
    /// Refuses a database file inside the report directory `out` (see
    /// [`check_database_outside`]).
    pub(super) fn check_outside(&self, out: &Path) -> Result<(), Failure> {
        let at = campaign::locate(self.db.as_deref(), self.no_db, &|k| std::env::var(k).ok());
        match at {
            Some(at) => check_database_outside(&at, out),
            None => Ok(()),
        }
    }
}

/// Refuses a database file inside the report directory `out`: it would
/// be swapped away with the old report, or become part of the new one
/// after it is signed (and break its `verify`). A file named by the user
/// must be in a directory that exists. Checked before a run starts, by
/// `plan`, `merge` and the Python package's `run`.
pub fn check_database_outside(at: &Location, out: &Path) -> Result<(), Failure> {
    let (db, named) = match at {
        Location::File(db) => (db, true),
        Location::Default(db) => (db, false),
        Location::Server(_) | Location::Off => return Ok(()),
    };
    let (db_abs, out_abs) = (absolute(db), absolute(out));
    if db_abs.starts_with(&out_abs) {
        return Err(UsageError(format!(
            "the results database `{}` is inside the report directory `{}`, which a run replaces whole\n    hint: keep the database outside it, e.g. --db results.sqlite beside the reports",
            db.display(),
            out.display()
        ))
        .into());
    }
    // Inside --out first: making the directory would not help there.
    if named {
        crate::campaign::check_directory(db)?;
    }
    Ok(())
}

/// `path` made absolute and free of symbolic links as far as it exists
/// (the rest is appended as given, `.` and `..` resolved by name).
fn absolute(path: &Path) -> PathBuf {
    let joined = std::env::current_dir()
        .map(|d| d.join(path))
        .unwrap_or_else(|_| path.to_path_buf());
    let mut base = joined.clone();
    let mut rest = Vec::new();
    while !base.exists() {
        match (base.file_name(), base.parent()) {
            (Some(name), Some(parent)) => {
                rest.push(name.to_os_string());
                base = parent.to_path_buf();
            }
            _ => break,
        }
    }
    let mut out = std::fs::canonicalize(&base).unwrap_or(base);
    for part in rest.into_iter().rev() {
        match part.to_str() {
            Some("..") => {
                out.pop();
            }
            Some(".") => {}
            _ => out.push(part),
        }
    }
    out
}

/// `--db` of the commands that read the database.
#[derive(Args, Debug, Clone)]
pub(super) struct DbArg {
    /// Results database: a file, or a postgres:// URL [default: as for
    /// `plan`].
    #[arg(long, value_name = "PATH|URL")]
    db: Option<PathBuf>,
}

impl DbArg {
    /// The database asked for, a file or a server; no place at all is a
    /// usage error.
    pub(super) fn location(&self) -> Result<Location, Failure> {
        match campaign::locate(self.db.as_deref(), false, &|k| std::env::var(k).ok()) {
            Some(Location::Off) | None => Err(no_place().into()),
            Some(at) => Ok(at),
        }
    }
}

fn no_place() -> UsageError {
    UsageError(
        "no results database: HOME, XDG_DATA_HOME and LEDFLICKER_DB are unset\n    hint: pass --db PATH".to_string(),
    )
}

/// Records the finished report of `plan` or `merge`. The report is
/// written and complete whatever happens here, so a failure is a warning
/// that says how to record it later, and the exit code stays the run's.
pub(super) fn record_finished(
    args: &RecordArgs,
    results: &crate::model::Results,
    dir: &Path,
    source: Source,
    signer: Option<&str>,
) {
    let _t = crate::timings::span("record in the results database");
    let at = match campaign::locate(args.db.as_deref(), args.no_db, &|k| std::env::var(k).ok()) {
        Some(Location::Off) => return,
        Some(at) => at,
        None => {
            eprintln!("warning: the run was not recorded: {}", no_place().0);
            return;
        }
    };
    let provenance = Provenance {
        source,
        signer: signer.map(str::to_string),
        signature: if signer.is_some() {
            Signature::Signed
        } else {
            Signature::Unsigned
        },
    };
    let recorded = Database::open(&at)
        .and_then(|mut db| campaign::record::record(&mut db, results, dir, &provenance));
    if let Err(e) = recorded {
        let e = Failure::from(e);
        eprintln!(
            "warning: the run was not recorded in the results database: {}\n    hint: the report in `{}` is complete; record it later with `ledflicker import {}`, or pass --no-db",
            e.message(),
            dir.display(),
            dir.display()
        );
    }
}

/// `ledflicker import` arguments.
#[derive(Args, Debug)]
pub(super) struct ImportArgs {
    /// Report directories written by `plan` or `merge`.
    #[arg(required = true)]
    dirs: Vec<PathBuf>,
    /// Trusted certificate (PEM or DER), or a directory of them;
    /// repeatable. A signed report is recorded as `intact` only when every
    /// signer's certificate chains to one of them (else `untrusted`).
    #[arg(long = "trust", value_name = "CERT")]
    trust: Vec<PathBuf>,
    #[command(flatten)]
    db: DbArg,
}

/// Records each report directory: its verdicts judged again from its
/// values and limits (a report whose conclusions do not follow is
/// refused); a signed one verified first and recorded with what the
/// check found (`intact` with a trusted signer, `untrusted`, `broken`).
pub(super) fn import(a: ImportArgs) -> Result<ExitCode, Failure> {
    let trusted = super::sign::trusted(&a.trust)?;
    let mut db = Database::open(&a.db.location()?)?;
    for dir in &a.dirs {
        let results_path = dir.join("results.json");
        let text = crate::util::read_input_to_string(&results_path).map_err(|e| {
            UsageError(format!(
                "cannot read `{}`: {e}\n    hint: pass report directories written by `ledflicker plan` or `merge`",
                results_path.display()
            ))
        })?;
        let results = crate::model::read_results(&text)
            .map_err(|e| UsageError(format!("`{}`: {e}", results_path.display())))?;
        campaign::rejudge::refuse_edited(
            dir,
            &results,
            ", so it is not recorded",
            "import the report as ledflicker wrote it, or run the plan again",
        )?;
        let (signature, signer) = super::sign::signature_of(dir, &trusted);
        if signature == Signature::Broken {
            eprintln!(
                "warning: `{}`: a hash or signature does not match (see `ledflicker verify {}`); recorded as broken",
                dir.display(),
                dir.display()
            );
        }
        let provenance = Provenance {
            source: Source::Import,
            signer,
            signature,
        };
        let id = campaign::record::record(&mut db, &results, dir, &provenance)?;
        outln!(
            "run {id}: `{}`, plan `{}`, {} {} firmware {}, {} ({})",
            dir.display(),
            results.plan.id,
            results.dut.model,
            results.dut.serial,
            results.dut.firmware,
            results.verdict.as_str(),
            signature.as_str()
        )?;
    }
    Ok(ExitCode::Pass)
}

/// `ledflicker history` arguments.
#[derive(Args, Debug)]
pub(super) struct HistoryArgs {
    #[command(flatten)]
    db: DbArg,
    /// Only runs of this camera (`[dut] model`).
    #[arg(long)]
    camera: Option<String>,
    /// Only runs of this serial number (`[dut] serial`).
    #[arg(long)]
    serial: Option<String>,
    /// Only runs of this firmware (`[dut] firmware`).
    #[arg(long)]
    firmware: Option<String>,
    /// Only runs of this plan id.
    #[arg(long)]
    plan: Option<String>,
    /// Only runs whose report date is on or after YYYY-MM-DD.
    #[arg(long)]
    since: Option<String>,
    /// Only runs whose report date is on or before YYYY-MM-DD.
    #[arg(long)]
    until: Option<String>,
    /// Only runs with this verdict.
    #[arg(long, value_parser = ["pass", "fail", "info"])]
    verdict: Option<String>,
    /// Print the runs as a JSON array.
    #[arg(long)]
    json: bool,
    /// Also write the runs as one standalone HTML page: by camera and
    /// firmware, each linked to its report, with trend charts.
    #[arg(long, value_name = "FILE")]
    html: Option<PathBuf>,
}

impl HistoryArgs {
    pub(super) fn filter(&self) -> Result<Filter, Failure> {
        for (flag, d) in [("--since", &self.since), ("--until", &self.until)] {
            if let Some(d) = d.as_deref().filter(|d| !crate::util::is_calendar_date(d)) {
                return Err(UsageError(format!(
                    "{flag} `{d}` is not a date YYYY-MM-DD (e.g. 2026-11-23)"
                ))
                .into());
            }
        }
        Ok(Filter {
            camera: self.camera.clone(),
            serial: self.serial.clone(),
            firmware: self.firmware.clone(),
            plan: self.plan.clone(),
            since: self.since.clone(),
            until: self.until.clone(),
            verdict: self.verdict.clone(),
        })
    }
}

/// Lists the runs the filters select, oldest first.
pub(super) fn history(a: HistoryArgs) -> Result<ExitCode, Failure> {
    let filter = a.filter()?;
    let db = Database::open_existing(&a.db.location()?)?;
    let runs = query::history(&db, &filter)?;
    if let Some(path) = &a.html {
        write_page(path, &runs, db.path(), &filter)?;
    }
    if a.json {
        outln!("{}", serde_json::to_string_pretty(&runs)?)?;
    } else {
        out!("{}", table(&runs))?;
    }
    Ok(ExitCode::Pass)
}

/// The runs as an aligned text table, one line each.
fn table(runs: &[RunRow]) -> String {
    let header = [
        "run",
        "date",
        "plan",
        "camera",
        "serial",
        "firmware",
        "verdict",
        "cases",
        "fail",
        "signature",
        "source",
        "report",
    ];
    let rows: Vec<[String; 12]> = runs
        .iter()
        .map(|r| {
            [
                r.id.to_string(),
                r.date.clone(),
                r.plan_id.clone(),
                r.model.clone(),
                r.serial.clone(),
                r.firmware.clone(),
                r.verdict.clone(),
                r.cases[0].to_string(),
                r.cases[2].to_string(),
                r.signature.clone(),
                r.source.clone(),
                r.report_dir.clone(),
            ]
        })
        .collect();
    let mut widths = header.map(str::len);
    for row in &rows {
        for (w, cell) in widths.iter_mut().zip(row) {
            *w = (*w).max(cell.chars().count());
        }
    }
    let line = |cells: &[&str]| {
        let mut s = cells
            .iter()
            .zip(widths)
            .map(|(c, w)| format!("{c:<w$}"))
            .collect::<Vec<_>>()
            .join("  ");
        s.truncate(s.trim_end().len());
        s.push('\n');
        s
    };
    let mut text = line(&header);
    for row in &rows {
        text.push_str(&line(&row.each_ref().map(String::as_str)));
    }
    if rows.is_empty() {
        text.push_str("(no runs)\n");
    }
    text
}

/// The first bytes of a page `history --html` writes: the doctype, then
/// its title before the end of its head.
fn is_history_page(head: &[u8]) -> bool {
    let text = String::from_utf8_lossy(head);
    let head_part = text.split("</head>").next().unwrap_or("");
    text.starts_with("<!DOCTYPE html>") && head_part.contains("<title>ledflicker history:")
}

/// The filters of `history` in words, for the page.
fn in_words(filter: &Filter) -> String {
    [
        ("camera", &filter.camera),
        ("serial", &filter.serial),
        ("firmware", &filter.firmware),
        ("plan", &filter.plan),
        ("since", &filter.since),
        ("until", &filter.until),
        ("verdict", &filter.verdict),
    ]
    .iter()
    .filter_map(|(k, v)| v.as_ref().map(|v| format!("{k} {v}")))
    .collect::<Vec<_>>()
    .join(", ")
}

/// Writes the history page of `runs` to `path`. A file there that is not
/// such a page is the user's and is left alone: only a regular file that
/// starts as the page does (its doctype, then its title within its head)
/// is replaced; a FIFO, a device, a directory or a link is refused unread.
fn write_page(path: &Path, runs: &[RunRow], db: &Path, filter: &Filter) -> Result<(), Failure> {
    let refuse = |why: &str| {
        UsageError(format!(
            "`{}` {why}; refusing to replace it\n    hint: give another file name",
            path.display()
        ))
    };
    match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(refuse(&format!("cannot be examined ({e})")).into()),
        Ok(m) if !m.file_type().is_file() => {
            return Err(refuse("exists and is not a regular file").into());
        }
        Ok(_) => {
            use std::io::Read;
            let mut head = Vec::new();
            crate::util::open_input(path)
                .and_then(|f| f.take(4096).read_to_end(&mut head))
                .map_err(|e| refuse(&format!("cannot be read ({e})")))?;
            if !is_history_page(&head) {
                return Err(
                    refuse("exists and is not a page `ledflicker history --html` wrote").into(),
                );
            }
        }
    }
    let date = super::args::report_date(None)?;
    let view = crate::campaign::pages::history_view(runs, db, &in_words(filter), &date);
    let html = crate::report::history::html(&view)?;
    crate::util::write_atomic(path, html.as_bytes())
        .map_err(|e| UsageError(format!("cannot write `{}`: {e}", path.display())))?;
    Ok(())
}
