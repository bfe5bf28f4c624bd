//! `ledflicker rig check PLAN` and `ledflicker plan --dry-run`: a lab
//! rig's light source (`[source]`, docs/lab.md) looked at before a run.
//! `rig check` connects, prints the instrument's identity, its error
//! queue and the plan's settings, and sends nothing but the identity and
//! error queries; the dry run connects to nothing and prints every line a
//! run would send, case by case, with the planned times. `rig simulate`
//! runs the SCPI instrument simulator on 127.0.0.1, to try a plan
//! without an instrument.

use clap::{Args, Subcommand};

use super::output::outln;
use super::{ExitCode, Failure};
use crate::backend::scpi::{self, Instrument};
use crate::plan::source::SourceConfig;
use crate::plan::{self, Plan};

#[derive(Args, Debug)]
pub(super) struct RigArgs {
    #[command(subcommand)]
    action: RigAction,
}

#[derive(Subcommand, Debug)]
enum RigAction {
    /// Connect to the plan's light source, print its identity, its error
    /// queue and the plan's settings; sets nothing (the LED stays as it is).
    Check {
        /// Plan file, or a plan name from test-plans/.
        plan: String,
    },
    /// Run an SCPI instrument simulator on 127.0.0.1 until Ctrl-C: it
    /// answers `*IDN?` and the error query, and records every line it is
    /// sent (docs/lab.md, "Trying it without hardware").
    Simulate {
        /// TCP port to listen on; 0 picks a free one.
        #[arg(long, default_value_t = scpi_port())]
        port: u16,
        /// Append every line received to this file, as `<Unix time, s>
        /// <connection> <line>`.
        #[arg(long)]
        log: Option<std::path::PathBuf>,
    },
}

const fn scpi_port() -> u16 {
    crate::plan::source::DEFAULT_PORT
}

pub(super) fn rig(args: RigArgs) -> Result<ExitCode, Failure> {
    match args.action {
        RigAction::Check { plan } => check(&plan),
        RigAction::Simulate { port, log } => simulate(port, log.as_deref()),
    }
}

/// Serves as an instrument until SIGINT or SIGTERM, then says how many
/// lines it received.
fn simulate(port: u16, log: Option<&std::path::Path>) -> Result<ExitCode, Failure> {
    use crate::backend::scpi::simulator::{Faults, SimInstrument};
    crate::interrupt::install();
    let sim = SimInstrument::start_at(port, Faults::default(), log).map_err(|e| {
        Failure::Internal(format!(
            "cannot run the instrument simulator on 127.0.0.1:{port}{}: {e}",
            log.map(|l| format!(" with the log `{}`", l.display()))
                .unwrap_or_default()
        ))
    })?;
    outln!(
        "SCPI instrument simulator on 127.0.0.1:{} (Ctrl-C stops it)",
        sim.port()
    )?;
    while crate::interrupt::requested().is_none() {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let lines = sim.lines();
    let last = lines
        .iter()
        .rev()
        .find(|l| l.contains("OUTP"))
        .map(|l| format!("; the last output line was `{l}`"));
    eprintln!(
        "stopped: {} line(s) received on {} connection(s){}",
        lines.len(),
        sim.connections(),
        last.unwrap_or_default()
    );
    Ok(ExitCode::Pass)
}

fn check(arg: &str) -> Result<ExitCode, Failure> {
    let plan = super::validate::load(arg, crate::plan::ResourceLimits::unbounded())?;
    let Some(source) = &plan.source else {
        return Err(crate::error::UsageError(format!(
            "plan `{}` has no [source]: there is no instrument to check\n    hint: docs/lab.md shows a [source] table",
            plan.id
        ))
        .into());
    };
    settings(&plan, source)?;
    let (identity, errors) = Instrument::probe(source).map_err(|e| {
        // An instrument that is off, elsewhere or not yet wired is the
        // usual reason; the simulator lets the plan be tried without it.
        let hint = if e.is_connection() {
            format!(
                "\n    hint: check that the instrument is on and listening at {}:{} ([source] host and port, or ${}); to try the plan without it, start `ledflicker rig simulate` and set {}=127.0.0.1:PORT",
                source.host,
                source.port,
                crate::plan::source::ADDRESS_ENV,
                crate::plan::source::ADDRESS_ENV
            )
        } else {
            String::new()
        };
        Failure::Internal(format!("light source: {e}{hint}"))
    })?;
    outln!("identity: {identity}")?;
    if errors.is_empty() {
        outln!("error queue: empty")?;
    } else {
        for (code, message) in &errors {
            outln!("error queue: {code}, \"{message}\" (read and cleared)")?;
        }
    }
    Ok(ExitCode::Pass)
}

/// The plan's light source and capture command, as a run would use them.
fn settings(plan: &Plan, s: &SourceConfig) -> Result<(), Failure> {
    outln!(
        "light source: {} at {}:{}, channel {}",
        s.instrument.name(),
        s.host,
        s.port,
        s.channel
    )?;
    outln!(
        "  PWM: square wave {} Vpp, offset {} V (low {} V, high {} V); ON: steady {} V",
        scpi::scpi_number(s.amplitude_vpp),
        scpi::scpi_number(s.offset_v),
        scpi::scpi_number(s.low_v()),
        scpi::scpi_number(s.high_v()),
        scpi::scpi_number(s.high_v())
    )?;
    outln!(
        "  time limit {} s per answer, {} reconnects, {} s dark lead-in",
        scpi::scpi_number(s.timeout_s),
        s.reconnects,
        scpi::scpi_number(s.lead_in_s)
    )?;
    if let Some(rec) = &plan.recorder {
        outln!(
            "camera recorder: {} frames ({} s at {} fps), {} s after the end",
            rec.frames,
            scpi::scpi_number(rec.duration_s),
            scpi::scpi_number(plan.dut.camera.fps),
            scpi::scpi_number(rec.tail_s)
        )?;
        outln!("  {}", rec.argv.join(" "))?;
    } else if let Some(cmd) = plan.capture.as_ref().and_then(|c| c.command.as_ref()) {
        outln!("capture command: {}", cmd.argv.join(" "))?;
    }
    Ok(())
}

/// `plan --dry-run`: every line the run would send, nothing connected.
pub(super) fn dry_run(plan: &Plan) -> Result<ExitCode, Failure> {
    let cases = plan::expand_cases(plan);
    outln!(
        "dry run of plan `{}`: {} cases; nothing is connected or sent",
        plan.id,
        cases.len()
    )?;
    let Some(source) = &plan.source else {
        outln!("the plan has no [source]: a run sends no instrument commands")?;
        return Ok(ExitCode::Pass);
    };
    settings(plan, source)?;
    let query = &source.commands.error_query;
    let checked = |lines: &mut Vec<String>| {
        if !query.is_empty() {
            lines.push(query.clone());
        }
    };
    outln!("on connecting:")?;
    for line in scpi::connect_lines(source) {
        outln!("  {line}")?;
    }
    for case in &cases {
        outln!("case {}:", case.id)?;
        let mut at = 0.0;
        for step in scpi::case_steps(source, case, &plan.sequence) {
            let mut lines = step.lines.clone();
            checked(&mut lines);
            for (i, line) in lines.iter().enumerate() {
                if i == 0 {
                    outln!("  {:>9.3} s  {:<8} {line}", at, step.name)?;
                } else {
                    outln!("  {:>11}  {:<8} {line}", "", "")?;
                }
            }
            at += step.hold_s;
        }
    }
    Ok(ExitCode::Pass)
}
