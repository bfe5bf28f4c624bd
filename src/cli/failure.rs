//! Why a command failed, and the exit code that says so. Every error a
//! command returns is a [`Failure`]: each error type of the library is
//! wrapped by one variant (`From`, so `?` converts it), and
//! [`Failure::exit_code`] maps every variant, and every variant of the
//! wrapped enums whose code depends on it, by an exhaustive `match`. A new
//! variant, or a new error type a command returns, does not compile until
//! it has its code. The codes are those of the table in [`super`] and the
//! README.
//!
//! Messages are printed as `error: ` and [`Failure::message`]: the error,
//! then each of its causes after `: `.

use std::error::Error as _;

use super::ExitCode;
use super::calibrate::NoEstimate;
use crate::backend::SetupError;
use crate::calibrate::ProfileError;
use crate::calibrate::frames::FrameError;
use crate::capture::CaptureError;
use crate::error::{NotBuiltIn, UsageError};
use crate::interrupt::Interrupted;
use crate::outdir::OutDirError;
use crate::pipeline::PipelineError;
use crate::plan::PlanError;
use crate::report::ReportError;
use crate::report::charts::ChartError;
use crate::runner::RunError;
use crate::shard::merge::MergeError;
use crate::shard::write::WriteError;
#[cfg(feature = "signoff")]
use crate::signoff::SignoffError;

/// Why a command could not do its work. Each variant says its exit code.
#[derive(Debug, thiserror::Error)]
pub enum Failure {
    /// The plan cannot be found, read or validated (2).
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// A flag, a file or an input of the user's is wrong (2).
    #[error(transparent)]
    Usage(#[from] UsageError),
    /// A command or option of a part this build lacks (2).
    #[error(transparent)]
    NotBuiltIn(#[from] NotBuiltIn),
    /// `merge`: the shards do not fit together (missing, duplicated, of
    /// another plan, tool or seed, damaged), or their plan cannot be
    /// loaded (2).
    #[error(transparent)]
    Shards(#[from] MergeError),
    /// `linetime`, `bands`, `calibrate`: no confident estimate (4).
    #[error(transparent)]
    NoEstimate(#[from] NoEstimate),
    /// SIGINT or SIGTERM stopped the command (128 + the signal).
    #[error(transparent)]
    Interrupted(#[from] Interrupted),
    /// The plan's backend could not be built: its input (2), a tool (3),
    /// or stopped (the signal's code).
    #[error(transparent)]
    Setup(#[from] SetupError),
    /// Frames of `linetime`, `bands`, `calibrate` could not be read: the
    /// input (2), a tool (3), or stopped (the signal's code).
    #[error(transparent)]
    Frames(#[from] FrameError),
    /// The run stopped: a backend or the thread pool broke (3), or a
    /// signal (its code).
    #[error(transparent)]
    Run(#[from] RunError),
    /// The output directory cannot be used: the user's directory (2) or
    /// the file system (3); see [`OutDirError::is_usage_error`].
    #[error(transparent)]
    OutDir(#[from] OutDirError),
    /// A report could not be written or read: a report file or output
    /// directory of the user's is at fault (2), or the tool (3).
    #[error(transparent)]
    Report(#[from] ReportError),
    /// A key could not be made or used, or a report not signed or
    /// verified: the user's key, certificate or report (2), or the tool (3).
    #[cfg(feature = "signoff")]
    #[error(transparent)]
    Signoff(#[from] SignoffError),
    /// The report stage of `plan` or `merge` failed: the code is its
    /// cause's.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    /// The run stage stopped: the case store (below) or the run (above).
    #[error(transparent)]
    RunStage(#[from] crate::pipeline::RunStageError),
    /// The case store failed (3), or cannot be resumed (2).
    #[error(transparent)]
    Store(#[from] crate::store::StoreError),
    /// The results database cannot be used: the user's file or request
    /// (2), or SQLite (3).
    #[error(transparent)]
    Campaign(#[from] crate::campaign::CampaignError),
    /// A shard directory could not be written (3).
    #[error(transparent)]
    ShardWrite(#[from] WriteError),
    /// A fitted camera profile could not be written or simulated back (3).
    #[error(transparent)]
    Profile(#[from] ProfileError),
    /// A chart could not be drawn (3).
    #[error(transparent)]
    Chart(#[from] ChartError),
    /// Output could not be serialised (3).
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// A file or standard output failed: a FIFO, device, socket or
    /// directory where a file was expected (2), anything else (3).
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// The tool broke, in its own words (3): a bench or a render step.
    #[error("{0}")]
    Internal(String),
    /// `source`, with what was being done when it happened; the code is
    /// the source's.
    #[error("{context}")]
    Context {
        /// What was being done, e.g. "cannot write the report to `DIR`".
        context: String,
        /// Why it failed.
        #[source]
        source: Box<Failure>,
    },
}

/// A plan that cannot be loaded fails as its cause does.
impl From<crate::pipeline::LoadError> for Failure {
    fn from(e: crate::pipeline::LoadError) -> Self {
        use crate::pipeline::LoadError;
        match e {
            LoadError::Plan(e) => Failure::Plan(e),
            LoadError::Interrupted(e) => Failure::Interrupted(e),
            LoadError::Address(e) => Failure::Usage(e),
        }
    }
}

impl Failure {
    /// The process exit code (the table in [`super`]).
    pub fn exit_code(&self) -> ExitCode {
        match self {
            Failure::Plan(_) | Failure::Usage(_) | Failure::NotBuiltIn(_) | Failure::Shards(_) => {
                ExitCode::Invalid
            }
            Failure::NoEstimate(_) => ExitCode::NoConfidence,
            Failure::Interrupted(i) => ExitCode::Signal(i.signal),
            Failure::Setup(e) => setup(e),
            Failure::Frames(e) => frames(e),
            Failure::Run(e) => run(e),
            Failure::OutDir(e) => out_dir(e),
            Failure::Report(e) => report(e),
            #[cfg(feature = "signoff")]
            Failure::Signoff(e) => signoff(e),
            Failure::Pipeline(e) => pipeline(e),
            Failure::ShardWrite(e) => shard_write(e),
            Failure::RunStage(e) => run_stage(e),
            Failure::Store(e) => store(e),
            Failure::Campaign(e) if e.is_usage_error() => ExitCode::Invalid,
            Failure::Campaign(_) => ExitCode::Internal,
            Failure::Profile(_) | Failure::Chart(_) | Failure::Json(_) | Failure::Internal(_) => {
                ExitCode::Internal
            }
            Failure::Io(e) => io(e),
            Failure::Context { source, .. } => source.exit_code(),
        }
    }

    /// The error and its causes, each after `: `, as printed after
    /// `error: `.
    pub fn message(&self) -> String {
        let mut text = self.to_string();
        let mut cause = self.source();
        while let Some(c) = cause {
            text.push_str(": ");
            text.push_str(&c.to_string());
            cause = c.source();
        }
        text
    }
}

/// `.with_context(|| ...)` on any result whose error is a [`Failure`] or
/// converts to one: says what was being done, keeps the source's code.
pub(crate) trait Context<T> {
    /// The error, as the source of [`Failure::Context`] with `context()`.
    fn with_context<C: std::fmt::Display>(self, context: impl FnOnce() -> C) -> Result<T, Failure>;
}

impl<T, E: Into<Failure>> Context<T> for Result<T, E> {
    fn with_context<C: std::fmt::Display>(self, context: impl FnOnce() -> C) -> Result<T, Failure> {
        self.map_err(|e| Failure::Context {
            context: context().to_string(),
            source: Box::new(e.into()),
        })
    }
}

/// A FIFO, device, socket or directory given where a file is read
/// ([`crate::util::open_input`]) is the user's input (2); any other I/O
/// failure is the tool's or the system's (3).
fn io(e: &std::io::Error) -> ExitCode {
    if crate::util::is_not_regular(e) {
        ExitCode::Invalid
    } else {
        ExitCode::Internal
    }
}

/// A capture the user gave is unreadable or inconsistent (2), the tool
/// reading it (ffmpeg) is missing or broke (3), or the user stopped it.
fn capture(e: &CaptureError) -> ExitCode {
    match e {
        CaptureError::Read { .. }
        | CaptureError::Frame { .. }
        | CaptureError::RoiOutside { .. }
        | CaptureError::Invalid { .. } => ExitCode::Invalid,
        CaptureError::Tool { .. } => ExitCode::Internal,
        CaptureError::Interrupted { source, .. } => ExitCode::Signal(source.signal),
    }
}

fn setup(e: &SetupError) -> ExitCode {
    match e {
        SetupError::Captures { source, .. } => capture(source),
        SetupError::Interrupted { source, .. } => ExitCode::Signal(source.signal),
        SetupError::NoCommand => ExitCode::Invalid,
    }
}

fn frames(e: &FrameError) -> ExitCode {
    match e {
        FrameError::Read { .. } | FrameError::Invalid { .. } => ExitCode::Invalid,
        FrameError::Capture(c) => capture(c),
    }
}

/// A run stops on a broken backend or thread pool (the tool's fault: the
/// plan was validated), or on a signal.
fn run(e: &RunError) -> ExitCode {
    match e {
        RunError::Backend(_) | RunError::BadTrace { .. } | RunError::Threads { .. } => {
            ExitCode::Internal
        }
        RunError::Interrupted(i) => ExitCode::Signal(i.signal),
    }
}

fn out_dir(e: &OutDirError) -> ExitCode {
    if e.is_usage_error() {
        ExitCode::Invalid
    } else {
        ExitCode::Internal
    }
}

fn pipeline(e: &PipelineError) -> ExitCode {
    match e {
        PipelineError::Interrupted(i) => ExitCode::Signal(i.signal),
        PipelineError::OutDir(o) => out_dir(o),
        PipelineError::Golden { source, .. } | PipelineError::Write { source, .. } => {
            report(source)
        }
        #[cfg(feature = "signoff")]
        PipelineError::Sign { source, .. } => signoff(source),
    }
}

/// A report file that is not what ledflicker writes (an earlier report,
/// a golden results.json) is the user's input (2); so is an output
/// directory refused for the user's reasons. Rendering is the tool's (3).
fn report(e: &ReportError) -> ExitCode {
    match e {
        ReportError::Io { source, .. } => io(source),
        ReportError::OutDir(o) => out_dir(o),
        ReportError::Invalid { .. } => ExitCode::Invalid,
        ReportError::Template { .. }
        | ReportError::Chart(_)
        | ReportError::Cases(_)
        | ReportError::Json(_)
        | ReportError::Csv(_)
        | ReportError::Junit(_)
        | ReportError::Pdf { .. } => ExitCode::Internal,
    }
}

/// Keys, certificates and the report to sign are the user's input (2),
/// and so is a request refused as unsafe; a failing cryptographic step or
/// re-rendering the report is the tool's (3), except when the report on
/// disk is not one ledflicker wrote or holds a signed report (2).
#[cfg(feature = "signoff")]
fn signoff(e: &SignoffError) -> ExitCode {
    match e {
        SignoffError::Io { .. }
        | SignoffError::Key { .. }
        | SignoffError::Pdf(_)
        | SignoffError::Refused(_) => ExitCode::Invalid,
        SignoffError::Crypto(_) => ExitCode::Internal,
        SignoffError::Report(r) => match r {
            ReportError::Invalid { .. } | ReportError::OutDir(OutDirError::Signed { .. }) => {
                ExitCode::Invalid
            }
            ReportError::OutDir(OutDirError::Refused { .. } | OutDirError::Io { .. })
            | ReportError::Io { .. }
            | ReportError::Template { .. }
            | ReportError::Chart(_)
            | ReportError::Cases(_)
            | ReportError::Json(_)
            | ReportError::Csv(_)
            | ReportError::Junit(_)
            | ReportError::Pdf { .. } => ExitCode::Internal,
        },
    }
}

fn shard_write(e: &WriteError) -> ExitCode {
    match e {
        WriteError::Encode(_) | WriteError::Manifest(_) => ExitCode::Internal,
        WriteError::Io { source, .. } => io(source),
    }
}

/// A store that belongs to another run is the user's to sort out; any
/// other store failure is the tool's.
fn run_stage(e: &crate::pipeline::RunStageError) -> ExitCode {
    use crate::pipeline::RunStageError;
    match e {
        RunStageError::Store(e) => store(e),
        RunStageError::Run(e) => run(e),
        RunStageError::Cases { source, .. } => run_stage(source),
    }
}

/// A store that is another run's, or holds a case that cannot be read or
/// checked, is input the run refuses, as `merge` refuses such a shard.
fn store(e: &crate::store::StoreError) -> ExitCode {
    match e {
        crate::store::StoreError::Mismatch { .. } | crate::store::StoreError::Record { .. } => {
            ExitCode::Invalid
        }
        crate::store::StoreError::Sqlite { .. } | crate::store::StoreError::Io { .. } => {
            ExitCode::Internal
        }
    }
}

#[cfg(test)]
mod tests;
