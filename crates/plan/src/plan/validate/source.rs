//! `[source]` and `[source.commands]`: the SCPI light source of a command
//! plan, from the serde mirror to a validated [`SourceConfig`].

use crate::plan::check::{Checker, keep};
use crate::plan::raw::{RawSource, RawSourceCommands};
use crate::plan::source::{CommandSet, DEFAULT_PORT, InstrumentKind, PLACEHOLDERS, SourceConfig};

/// Longest wait for a connection or an answer, seconds.
const TIMEOUT_S_RANGE: (f64, f64) = (0.1, 600.0);
/// Dark lead-in before the ON step, seconds.
const LEAD_IN_S_RANGE: (f64, f64) = (0.0, 600.0);
/// Amplitude, volts peak to peak: no bench generator gives more.
const AMPLITUDE_VPP_RANGE: (f64, f64) = (1e-3, 100.0);
/// Offset, volts.
const OFFSET_V_RANGE: (f64, f64) = (-50.0, 50.0);

/// Validates `[source]`; `command` is true for the command backend, the
/// only one that drives a light. `None` when absent or invalid (an error
/// was pushed in the second case).
pub(super) fn source_table(
    c: &mut Checker<'_>,
    raw: Option<RawSource>,
    command: bool,
) -> (Option<SourceConfig>, bool) {
    let Some(raw) = raw else {
        return (None, false);
    };
    if !command {
        c.error(
            "source",
            "only the command backend drives a light source",
            Some("set [dut] backend = \"command\" (its [capture] command records the camera), or remove [source]"),
        );
        return (None, true);
    }
    let cfg = source_config(c, raw);
    let failed = cfg.is_none();
    (cfg, failed)
}

fn source_config(c: &mut Checker<'_>, raw: RawSource) -> Option<SourceConfig> {
    let mut ok = true;
    let names: Vec<(&str, InstrumentKind)> = InstrumentKind::NAMES.to_vec();
    let instrument = c.required(
        raw.instrument,
        "source.instrument",
        "one of \"keysight-33500b\", \"rigol-dg1000z\", \"siglent-sdg\" or \"custom\"",
    );
    let instrument = instrument
        .and_then(|v| c.choice(Some(v), "source.instrument", InstrumentKind::Custom, &names));
    let host = c.required(
        raw.host,
        "source.host",
        "the instrument's IP address or host name, e.g. \"192.168.1.50\"",
    );
    let host = host.filter(|h| {
        let valid = !h.is_empty() && !h.contains(char::is_whitespace) && !h.contains('/');
        if !valid {
            c.error(
                "source.host",
                format!("`{h}` is not a host name or IP address"),
                Some("give the address only, e.g. \"192.168.1.50\"; the port is `port`"),
            );
        }
        valid
    });
    let mut cfg = SourceConfig {
        instrument: InstrumentKind::Custom,
        host: String::new(),
        port: DEFAULT_PORT,
        channel: 1,
        amplitude_vpp: 5.0,
        offset_v: 2.5,
        timeout_s: 5.0,
        lead_in_s: 1.0,
        reconnects: 2,
        commands: CommandSet {
            identify: String::new(),
            error_query: String::new(),
            setup: Vec::new(),
            steady: Vec::new(),
            pwm: Vec::new(),
            output_on: Vec::new(),
            output_off: Vec::new(),
        },
    };
    let integer = |c: &mut Checker<'_>, v: i64, key: &str, lo: i64, hi: i64, hint: &str| {
        if (lo..=hi).contains(&v) {
            Some(v)
        } else {
            c.error(key, format!("{v} is outside {lo}..={hi}"), Some(hint));
            None
        }
    };
    let port = raw.port.map(|v| {
        integer(
            c,
            v,
            "source.port",
            1,
            65535,
            "LXI instruments listen on 5025",
        )
        .map(|v| v as u16)
    });
    keep(&mut cfg.port, port, &mut ok);
    let channel = raw.channel.map(|v| {
        integer(c, v, "source.channel", 1, 16, "the output channel, from 1").map(|v| v as u32)
    });
    keep(&mut cfg.channel, channel, &mut ok);
    let reconnects = raw.reconnects.map(|v| {
        integer(
            c,
            v,
            "source.reconnects",
            0,
            10,
            "how often a dropped connection is reopened",
        )
        .map(|v| v as u32)
    });
    keep(&mut cfg.reconnects, reconnects, &mut ok);
    let amplitude = raw.amplitude_vpp.map(|v| {
        let hint = "volts peak to peak of the square wave, e.g. 5.0 for a 0-5 V drive";
        c.within(v, "source.amplitude-vpp", AMPLITUDE_VPP_RANGE, " Vpp", hint)
    });
    // The default offset puts the low level at 0 V, whatever the amplitude.
    let offset_default = amplitude.flatten().unwrap_or(cfg.amplitude_vpp) / 2.0;
    keep(&mut cfg.amplitude_vpp, amplitude, &mut ok);
    cfg.offset_v = offset_default;
    let offset = raw.offset_v.map(|v| {
        let hint = "volts; the default, half the amplitude, puts the low level at 0 V";
        c.within(v, "source.offset-v", OFFSET_V_RANGE, " V", hint)
    });
    keep(&mut cfg.offset_v, offset, &mut ok);
    let timeout = raw.timeout_s.map(|v| {
        let hint = "seconds to wait for the connection or an answer, e.g. 5.0";
        c.within(v, "source.timeout-s", TIMEOUT_S_RANGE, " s", hint)
    });
    keep(&mut cfg.timeout_s, timeout, &mut ok);
    let lead_in = raw.lead_in_s.map(|v| {
        let hint = "seconds of darkness recorded before the ON step, e.g. 1.0";
        c.within(v, "source.lead-in-s", LEAD_IN_S_RANGE, " s", hint)
    });
    keep(&mut cfg.lead_in_s, lead_in, &mut ok);
    let instrument = instrument?;
    cfg.instrument = instrument;
    cfg.commands = commands(c, instrument, raw.commands)?;
    cfg.host = host?;
    ok.then_some(cfg)
}

/// The template of `instrument` with the plan's lines over it; a custom
/// instrument must give every action.
fn commands(
    c: &mut Checker<'_>,
    instrument: InstrumentKind,
    raw: Option<RawSourceCommands>,
) -> Option<CommandSet> {
    let custom = instrument == InstrumentKind::Custom;
    let Some(raw) = raw else {
        if custom {
            c.error(
                "source.commands",
                "a custom instrument needs its commands",
                Some("give [source.commands] with identify, error-query, steady, pwm, output-on and output-off (docs/lab.md)"),
            );
        }
        return instrument.template();
    };
    let mut set = instrument.template().unwrap_or(CommandSet {
        identify: "*IDN?".into(),
        error_query: String::new(),
        setup: Vec::new(),
        steady: Vec::new(),
        pwm: Vec::new(),
        output_on: Vec::new(),
        output_off: Vec::new(),
    });
    let mut ok = true;
    let mut line = |c: &mut Checker<'_>, v: Option<String>, key: &str, slot: &mut String| {
        let Some(v) = v else {
            if custom && key != "identify" {
                let hint =
                    "a custom instrument gives every action; an empty string: no error queue";
                c.error(
                    &format!("source.commands.{key}"),
                    "missing required key",
                    Some(hint),
                );
                ok = false;
            }
            return;
        };
        if placeholders_known(c, &v, &format!("source.commands.{key}")) {
            *slot = v;
        } else {
            ok = false;
        }
    };
    line(c, raw.identify, "identify", &mut set.identify);
    line(c, raw.error_query, "error-query", &mut set.error_query);
    let mut lines =
        |c: &mut Checker<'_>, v: Option<Vec<String>>, key: &str, slot: &mut Vec<String>| {
            let full = format!("source.commands.{key}");
            let Some(v) = v else {
                if custom && key != "setup" {
                    c.error(
                        &full,
                        "missing required key",
                        Some("a list of SCPI lines, e.g. [\"OUTP1 OFF\"]"),
                    );
                    ok = false;
                }
                return;
            };
            if key != "setup" && v.is_empty() {
                c.error(
                    &full,
                    "no command given",
                    Some("list at least one SCPI line"),
                );
                ok = false;
                return;
            }
            let mut good = true;
            for (i, l) in v.iter().enumerate() {
                good &= placeholders_known(c, l, &format!("{full}[{i}]"));
            }
            if good {
                *slot = v;
            } else {
                ok = false;
            }
        };
    lines(c, raw.setup, "setup", &mut set.setup);
    lines(c, raw.steady, "steady", &mut set.steady);
    lines(c, raw.pwm, "pwm", &mut set.pwm);
    lines(c, raw.output_on, "output-on", &mut set.output_on);
    lines(c, raw.output_off, "output-off", &mut set.output_off);
    ok.then_some(set)
}

/// True when every `{name}` of `line` is a known placeholder and the line
/// is one line of printable text; reports the first problem otherwise.
fn placeholders_known(c: &mut Checker<'_>, line: &str, key: &str) -> bool {
    if line.chars().any(char::is_control) {
        c.error(
            key,
            "a command holds a control character (a line break?)",
            Some("give one SCPI line per list entry"),
        );
        return false;
    }
    let mut rest = line;
    while let Some(open) = rest.find('{') {
        let after = &rest[open + 1..];
        let Some(close) = after.find('}') else {
            c.error(
                key,
                "a `{` without its `}`",
                Some("placeholders look like {frequency-hz}"),
            );
            return false;
        };
        let name = &after[..close];
        if !PLACEHOLDERS.contains(&name) {
            c.error(
                key,
                format!("unknown placeholder `{{{name}}}`"),
                Some(&format!("placeholders: {}", PLACEHOLDERS.join(", "))),
            );
            return false;
        }
        rest = &after[close + 1..];
    }
    true
}
