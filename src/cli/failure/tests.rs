//! Every variant of [`Failure`] against the exit-code table.

use std::collections::BTreeSet;
use std::io::{Error as IoError, ErrorKind};
use std::path::PathBuf;

use super::*;
use crate::backend::BackendError;
use crate::calibrate::bands::NoConfidence;

/// An `io::Error` as [`crate::util::open_input`] refuses a FIFO.
fn not_regular() -> IoError {
    IoError::new(
        ErrorKind::InvalidInput,
        crate::util::NotRegularFile("a FIFO (named pipe)"),
    )
}

fn json_error() -> serde_json::Error {
    serde_json::from_str::<u8>("x").unwrap_err()
}

fn path() -> PathBuf {
    PathBuf::from("some/file")
}

fn within(source: Failure, context: &str) -> Failure {
    Failure::Context {
        context: context.into(),
        source: Box::new(source),
    }
}

fn sigint() -> Interrupted {
    Interrupted { signal: 2 }
}

fn sigterm() -> Interrupted {
    Interrupted { signal: 15 }
}

fn capture_tool() -> CaptureError {
    CaptureError::Tool {
        path: path(),
        message: "ffmpeg not found".into(),
    }
}

fn capture_read() -> CaptureError {
    CaptureError::Read {
        path: path(),
        message: "no such file".into(),
    }
}

fn out_dir_io(kind: ErrorKind) -> OutDirError {
    OutDirError::Io {
        dir: path(),
        action: "create",
        path: path(),
        source: IoError::from(kind),
    }
}

fn signed() -> OutDirError {
    OutDirError::Signed { dir: path() }
}

fn invalid_report() -> ReportError {
    ReportError::Invalid {
        path: path(),
        message: "not a results.json".into(),
    }
}

/// The library's error types, each variant whose code differs (and the
/// nested causes that decide it), with the code the table documents:
/// 2 the user's plan, input or usage, 3 the tool or a backend, 7 no
/// confident estimate, 128 + the signal when stopped.
fn one_of_each() -> Vec<(Failure, i32)> {
    let mut all = input_failures();
    all.extend(reading_failures());
    all.extend(output_failures());
    all.extend(tool_failures());
    #[cfg(feature = "signoff")]
    all.extend(signoff_failures());
    all
}

/// The user's plan, flags or shards; no estimate; a signal.
fn input_failures() -> Vec<(Failure, i32)> {
    let plan_error = || PlanError::NotFound {
        name: "dayligth".into(),
        tried: "test-plans/".into(),
    };
    let usage = || UsageError("--threads must be at least 1".into());
    vec![
        (plan_error().into(), 2),
        (usage().into(), 2),
        (
            NotBuiltIn {
                what: "`sign`".into(),
                part: "the sign-off (feature `signoff`)",
            }
            .into(),
            2,
        ),
        (MergeError::Unfit(usage()).into(), 2),
        (MergeError::Plan(plan_error()).into(), 2),
        (
            NoEstimate {
                input: "`frame.png`".into(),
                reason: NoConfidence::TooFewRows { rows: 3 },
                hint: "use a taller frame or --roi",
            }
            .into(),
            7,
        ),
        (sigint().into(), 130),
        (sigterm().into(), 143),
    ]
}

/// Captures and frames read, and the run.
fn reading_failures() -> Vec<(Failure, i32)> {
    vec![
        (SetupError::NoCommand.into(), 2),
        (
            SetupError::Captures {
                plan: "p".into(),
                source: capture_read(),
            }
            .into(),
            2,
        ),
        (
            SetupError::Captures {
                plan: "p".into(),
                source: capture_tool(),
            }
            .into(),
            3,
        ),
        (
            SetupError::Captures {
                plan: "p".into(),
                source: CaptureError::Interrupted {
                    path: path(),
                    source: sigterm(),
                },
            }
            .into(),
            143,
        ),
        (
            SetupError::Interrupted {
                plan: "p".into(),
                capture: path(),
                source: sigint(),
            }
            .into(),
            130,
        ),
        (
            FrameError::Read {
                path: path(),
                message: "not an image".into(),
            }
            .into(),
            2,
        ),
        (
            FrameError::Invalid {
                message: "--roi is outside the frame".into(),
                hint: "check --roi".into(),
            }
            .into(),
            2,
        ),
        (
            FrameError::Capture(CaptureError::Frame {
                path: path(),
                frame: 3,
                message: "truncated".into(),
            })
            .into(),
            2,
        ),
        (
            FrameError::Capture(CaptureError::Invalid {
                path: path(),
                message: "no frames".into(),
                hint: "give a video".into(),
            })
            .into(),
            2,
        ),
        (FrameError::Capture(capture_tool()).into(), 3),
        (
            FrameError::Capture(CaptureError::Interrupted {
                path: path(),
                source: sigint(),
            })
            .into(),
            130,
        ),
        (
            RunError::Backend(BackendError {
                backend: "sim".into(),
                case: "c".into(),
                message: "broke".into(),
            })
            .into(),
            3,
        ),
        (
            RunError::BadTrace {
                case: "c".into(),
                message: "no PWM frames".into(),
            }
            .into(),
            3,
        ),
        (
            RunError::Threads {
                threads: 4,
                message: "no threads".into(),
            }
            .into(),
            3,
        ),
        (RunError::Interrupted(sigterm()).into(), 143),
    ]
}

/// The output directory and the report.
fn output_failures() -> Vec<(Failure, i32)> {
    vec![
        (
            OutDirError::Refused {
                dir: path(),
                message: "not a report directory".into(),
                hint: "choose another --out".into(),
            }
            .into(),
            2,
        ),
        (signed().into(), 2),
        (out_dir_io(ErrorKind::PermissionDenied).into(), 2),
        (out_dir_io(ErrorKind::StorageFull).into(), 3),
        (
            ReportError::Io {
                path: path(),
                source: not_regular(),
            }
            .into(),
            2,
        ),
        (
            ReportError::Io {
                path: path(),
                source: IoError::from(ErrorKind::NotFound),
            }
            .into(),
            3,
        ),
        (ReportError::OutDir(signed()).into(), 2),
        (
            ReportError::OutDir(out_dir_io(ErrorKind::StorageFull)).into(),
            3,
        ),
        (invalid_report().into(), 2),
        (
            ReportError::Template {
                template: "report.html.j2".into(),
                message: "undefined".into(),
            }
            .into(),
            3,
        ),
        (
            ReportError::Chart(ChartError {
                chart: "trace".into(),
                message: "broke".into(),
            })
            .into(),
            3,
        ),
        (ReportError::Json(json_error()).into(), 3),
        (
            ReportError::Pdf {
                message: "layout".into(),
            }
            .into(),
            3,
        ),
        (PipelineError::Interrupted(sigint()).into(), 130),
        (PipelineError::OutDir(signed()).into(), 2),
        (
            PipelineError::Golden {
                path: path(),
                source: invalid_report(),
            }
            .into(),
            2,
        ),
        (
            PipelineError::Write {
                out: path(),
                source: ReportError::Io {
                    path: path(),
                    source: IoError::from(ErrorKind::StorageFull),
                },
            }
            .into(),
            3,
        ),
    ]
}

/// The tool's own failures, and causes given context.
fn tool_failures() -> Vec<(Failure, i32)> {
    vec![
        (WriteError::Encode("cbor".into()).into(), 3),
        (
            crate::campaign::CampaignError::Unusable {
                path: path(),
                message: "it is not an SQLite database".into(),
            }
            .into(),
            2,
        ),
        (
            crate::campaign::CampaignError::Input("no run 7".into()).into(),
            2,
        ),
        (
            crate::campaign::CampaignError::Sqlite {
                path: path(),
                source: rusqlite::Error::InvalidQuery,
            }
            .into(),
            3,
        ),
        (
            crate::store::StoreError::Mismatch {
                path: path(),
                message: "its plan_hash is `a`".into(),
            }
            .into(),
            2,
        ),
        (
            crate::store::StoreError::Record {
                path: path(),
                idx: 3,
                id: String::new(),
                message: "cannot decode".into(),
            }
            .into(),
            2,
        ),
        (
            crate::pipeline::RunStageError::Cases {
                plan: "daylight".into(),
                source: Box::new(RunError::Interrupted(sigterm()).into()),
            }
            .into(),
            143,
        ),
        (
            crate::pipeline::RunStageError::Store(crate::store::StoreError::Mismatch {
                path: path(),
                message: "its case_count is `3`".into(),
            })
            .into(),
            2,
        ),
        (WriteError::Manifest(json_error()).into(), 3),
        (
            WriteError::Io {
                action: "write",
                path: path(),
                source: IoError::from(ErrorKind::StorageFull),
            }
            .into(),
            3,
        ),
        (ProfileError::ClosedLoop("no frames".into()).into(), 3),
        (
            ProfileError::Write {
                path: path(),
                error: IoError::from(ErrorKind::PermissionDenied),
            }
            .into(),
            3,
        ),
        (
            ChartError {
                chart: "advise".into(),
                message: "broke".into(),
            }
            .into(),
            3,
        ),
        (json_error().into(), 3),
        (not_regular().into(), 2),
        (IoError::from(ErrorKind::StorageFull).into(), 3),
        (Failure::Internal("bench failed: no CPU".into()), 3),
        (
            within(
                Failure::from(RunError::Interrupted(sigint())),
                "run of plan `p` failed",
            ),
            130,
        ),
        (
            within(
                Failure::from(invalid_report()),
                "cannot write the report to `r`",
            ),
            2,
        ),
        (
            within(
                Failure::from(IoError::from(ErrorKind::StorageFull)),
                "cannot write `svg`",
            ),
            3,
        ),
    ]
}

/// Keys, certificates and signing.
#[cfg(feature = "signoff")]
fn signoff_failures() -> Vec<(Failure, i32)> {
    vec![
        (
            SignoffError::Io {
                path: path(),
                source: IoError::from(ErrorKind::NotFound),
            }
            .into(),
            2,
        ),
        (
            SignoffError::Key {
                path: path(),
                message: "not PEM".into(),
            }
            .into(),
            2,
        ),
        (SignoffError::Pdf("no room".into()).into(), 2),
        (
            SignoffError::Refused("key inside the report".into()).into(),
            2,
        ),
        (SignoffError::Crypto("encoding".into()).into(), 3),
        (SignoffError::Report(invalid_report()).into(), 2),
        (
            SignoffError::Report(ReportError::OutDir(signed())).into(),
            2,
        ),
        (
            SignoffError::Report(ReportError::OutDir(OutDirError::Refused {
                dir: path(),
                message: "m".into(),
                hint: "h".into(),
            }))
            .into(),
            3,
        ),
        (
            SignoffError::Report(ReportError::Io {
                path: path(),
                source: not_regular(),
            })
            .into(),
            3,
        ),
        (
            within(
                Failure::from(SignoffError::Crypto("encoding".into())),
                "cannot sign `r`",
            ),
            3,
        ),
    ]
}

/// Every variant of [`Failure`]; the `match` in [`variant`] has no
/// catch-all arm, so a new variant must be named here too.
const VARIANTS: &[&str] = &[
    "Plan",
    "Usage",
    "NotBuiltIn",
    "Shards",
    "NoEstimate",
    "Interrupted",
    "Setup",
    "Frames",
    "Run",
    "OutDir",
    "Report",
    #[cfg(feature = "signoff")]
    "Signoff",
    "Pipeline",
    "ShardWrite",
    "RunStage",
    "Store",
    "Campaign",
    "Profile",
    "Chart",
    "Json",
    "Io",
    "Internal",
    "Context",
];

fn variant(f: &Failure) -> &'static str {
    match f {
        Failure::Plan(_) => "Plan",
        Failure::Usage(_) => "Usage",
        Failure::NotBuiltIn(_) => "NotBuiltIn",
        Failure::Shards(_) => "Shards",
        Failure::NoEstimate(_) => "NoEstimate",
        Failure::Interrupted(_) => "Interrupted",
        Failure::Setup(_) => "Setup",
        Failure::Frames(_) => "Frames",
        Failure::Run(_) => "Run",
        Failure::OutDir(_) => "OutDir",
        Failure::Report(_) => "Report",
        #[cfg(feature = "signoff")]
        Failure::Signoff(_) => "Signoff",
        Failure::Pipeline(_) => "Pipeline",
        Failure::ShardWrite(_) => "ShardWrite",
        Failure::RunStage(_) => "RunStage",
        Failure::Store(_) => "Store",
        Failure::Campaign(_) => "Campaign",
        Failure::Profile(_) => "Profile",
        Failure::Chart(_) => "Chart",
        Failure::Json(_) => "Json",
        Failure::Io(_) => "Io",
        Failure::Internal(_) => "Internal",
        Failure::Context { .. } => "Context",
    }
}

/// The codes in the first column of the README's exit-code table
/// ("130, 143" gives both).
fn documented_codes() -> BTreeSet<i32> {
    let readme = include_str!("../../../README.md");
    let table = readme
        .split("### Exit codes")
        .nth(1)
        .expect("README has an exit-code section");
    table
        .lines()
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .filter_map(|l| l.split('|').nth(1))
        .flat_map(|cell| cell.split(',').map(|c| c.trim().parse::<i32>()))
        .filter_map(Result::ok)
        .collect()
}

#[test]
fn every_failure_has_the_documented_exit_code() {
    let documented = documented_codes();
    assert_eq!(
        documented,
        BTreeSet::from([0, 1, 2, 3, 4, 5, 6, 7, 130, 143]),
        "the README's exit-code table changed: update this test and the variants' docs"
    );
    let samples = one_of_each();
    let seen: BTreeSet<&str> = samples.iter().map(|(f, _)| variant(f)).collect();
    let all: BTreeSet<&str> = VARIANTS.iter().copied().collect();
    assert_eq!(seen, all, "one_of_each() misses a variant");
    for (failure, code) in &samples {
        let got = failure.exit_code().code();
        assert_eq!(got, *code, "{}: {failure:?}", failure.message());
        assert!(documented.contains(&got), "{got} is not in the README");
        // An error is never an exit code of success or of a verdict.
        assert!(!matches!(got, 0 | 1), "{failure:?}");
    }
}

#[test]
fn the_message_is_the_error_then_each_cause() {
    let e = within(
        Failure::from(SetupError::Captures {
            plan: "p".into(),
            source: capture_tool(),
        }),
        "cannot start",
    );
    assert_eq!(
        e.message(),
        "cannot start: cannot read the captures of plan `p`: capture `some/file`: ffmpeg not found"
    );
    // A transparent wrapper says its error once.
    let e = Failure::from(RunError::Interrupted(sigint()));
    assert_eq!(e.message(), sigint().to_string());
}
