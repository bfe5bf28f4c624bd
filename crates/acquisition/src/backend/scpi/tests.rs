use std::time::Instant;

use super::simulator::{Faults, IDENTITY, SimInstrument};
use super::*;
use ledflicker_plan::plan::source::InstrumentKind;

fn config(kind: InstrumentKind, port: u16) -> SourceConfig {
    SourceConfig {
        instrument: kind,
        host: "127.0.0.1".into(),
        port,
        channel: 1,
        amplitude_vpp: 5.0,
        offset_v: 2.5,
        timeout_s: 2.0,
        lead_in_s: 0.0,
        reconnects: 2,
        commands: kind.template().unwrap(),
    }
}

fn case(frequency_hz: f64, duty: f64) -> TestCase {
    TestCase {
        index: 0,
        id: "c".into(),
        light_lux: 2000.0,
        frequency_hz,
        duty,
        seed: 0,
    }
}

const SHORT: Sequence = Sequence {
    on_s: 0.02,
    off_s: 0.02,
    pwm_s: 0.02,
};

/// Connects and runs one case; the simulator's lines.
fn run_case(
    kind: InstrumentKind,
    faults: Faults,
    c: &TestCase,
) -> (
    Result<Vec<ledflicker_plan::trace::SourceStep>, String>,
    Vec<String>,
) {
    let sim = SimInstrument::start(faults).unwrap();
    let cfg = config(kind, sim.port());
    let result = Instrument::connect(&cfg)
        .map_err(|e| e.to_string())
        .and_then(|mut inst| {
            assert_eq!(inst.identity(), IDENTITY);
            let steps = case_steps(&cfg, c, &SHORT);
            sequence::run(&mut inst, &steps, Instant::now(), &|| false).map_err(|e| e.to_string())
        });
    (result, sim.lines())
}

#[test]
fn the_keysight_template_sends_the_documented_sequence() {
    let (log, lines) = run_case(
        InstrumentKind::Keysight33500b,
        Faults::default(),
        &case(90.0, 0.1),
    );
    let log = log.unwrap();
    let e = "SYST:ERR?";
    let expected = [
        "*IDN?",
        "*CLS",
        "OUTP1:LOAD INF",
        e,
        // prepare
        "OUTP1 OFF",
        "SOUR1:FUNC DC",
        "SOUR1:VOLT:OFFS 5",
        e,
        // on
        "OUTP1 ON",
        e,
        // off
        "OUTP1 OFF",
        "SOUR1:FUNC SQU",
        "SOUR1:FREQ 90",
        "SOUR1:VOLT 5",
        "SOUR1:VOLT:OFFS 2.5",
        "SOUR1:FUNC:SQU:DCYC 10",
        e,
        // pwm
        "OUTP1 ON",
        e,
        // end
        "OUTP1 OFF",
        e,
    ];
    assert_eq!(lines, expected);
    let names: Vec<&str> = log.iter().map(|s| s.step.as_str()).collect();
    assert_eq!(names, ["prepare", "on", "off", "pwm", "end"]);
    // Each step after the lead-in (0 s here) is held its time, from the
    // host clock.
    for pair in log[1..].windows(2) {
        assert!(pair[1].time_s - pair[0].time_s >= 0.02 - 1e-9, "{log:?}");
    }
}

#[test]
fn the_rigol_and_siglent_templates_send_their_own_syntax() {
    let (rigol, lines) = run_case(
        InstrumentKind::RigolDg1000z,
        Faults::default(),
        &case(137.0, 0.25),
    );
    rigol.unwrap();
    for want in [
        ":OUTP1:IMP INF",
        ":SOUR1:FUNC DC",
        ":SOUR1:VOLT:OFFS 5",
        ":SOUR1:FREQ 137",
        ":SOUR1:FUNC:SQU:DCYC 25",
        ":OUTP1 ON",
    ] {
        assert!(lines.iter().any(|l| l == want), "{want} not in {lines:?}");
    }
    assert_eq!(lines.last().map(String::as_str), Some(":SYST:ERR?"));
    assert_eq!(lines[lines.len() - 2], ":OUTP1 OFF");
    let (siglent, lines) = run_case(
        InstrumentKind::SiglentSdg,
        Faults::default(),
        &case(137.0, 0.25),
    );
    siglent.unwrap();
    for want in [
        "C1:OUTP LOAD,HZ",
        "C1:BSWV WVTP,DC,OFST,5",
        "C1:BSWV WVTP,SQUARE,FRQ,137,AMP,5,OFST,2.5,DUTY,25",
        "C1:OUTP ON",
    ] {
        assert!(lines.iter().any(|l| l == want), "{want} not in {lines:?}");
    }
    assert_eq!(lines[lines.len() - 2], "C1:OUTP OFF");
}

#[test]
fn a_case_at_full_duty_gets_the_steady_level_for_its_pwm() {
    let sim = SimInstrument::start(Faults::default()).unwrap();
    let cfg = config(InstrumentKind::Keysight33500b, sim.port());
    let steps = case_steps(&cfg, &case(90.0, 1.0), &SHORT);
    let off = steps.iter().find(|s| s.name == "off").unwrap();
    assert_eq!(
        off.lines,
        ["OUTP1 OFF", "SOUR1:FUNC DC", "SOUR1:VOLT:OFFS 5"]
    );
}

#[test]
fn an_instrument_error_stops_the_case_with_its_message_and_leaves_the_output_off() {
    let faults = Faults {
        error_on: Some(("DCYC".into(), -222, "Data out of range".into())),
        ..Faults::default()
    };
    let (result, lines) = run_case(InstrumentKind::Keysight33500b, faults, &case(90.0, 0.001));
    let message = result.unwrap_err();
    assert!(message.contains("-222, \"Data out of range\""), "{message}");
    assert!(message.contains("after the `off` step"), "{message}");
    // The PWM step's output-on was never sent, and the output is off.
    let on = lines.iter().filter(|l| *l == "OUTP1 ON").count();
    assert_eq!(on, 1, "{lines:?}");
    let last_output = lines.iter().rev().find(|l| l.starts_with("OUTP1 O"));
    assert_eq!(last_output.map(String::as_str), Some("OUTP1 OFF"));
}

#[test]
fn an_instrument_that_does_not_answer_is_a_timeout_error() {
    let sim = SimInstrument::start(Faults {
        stall_on: Some("ERR?".into()),
        ..Faults::default()
    })
    .unwrap();
    let mut cfg = config(InstrumentKind::Keysight33500b, sim.port());
    cfg.timeout_s = 0.3;
    let t = Instant::now();
    let e = Instrument::connect(&cfg).unwrap_err().to_string();
    assert_eq!(
        e,
        format!(
            "the instrument at 127.0.0.1:{} did not answer `SYST:ERR?` within 0.3 s",
            sim.port()
        )
    );
    assert!(t.elapsed().as_secs_f64() < 2.0, "{:?}", t.elapsed());
}

#[test]
fn a_dropped_connection_is_reopened_and_the_step_sent_again() {
    // The first connection closes after 6 lines: in the prepare step.
    let faults = Faults {
        drop_after: Some(6),
        ..Faults::default()
    };
    let sim = SimInstrument::start(faults).unwrap();
    let cfg = config(InstrumentKind::Keysight33500b, sim.port());
    let mut inst = Instrument::connect(&cfg).unwrap();
    let steps = case_steps(&cfg, &case(90.0, 0.1), &SHORT);
    sequence::run(&mut inst, &steps, Instant::now(), &|| false).unwrap();
    assert_eq!(sim.connections(), 2);
    let second: Vec<String> = sim
        .received()
        .into_iter()
        .filter(|r| r.connection == 1)
        .map(|r| r.line)
        .collect();
    // The whole prepare step again, on the new connection.
    assert_eq!(
        second[..4],
        [
            "OUTP1 OFF",
            "SOUR1:FUNC DC",
            "SOUR1:VOLT:OFFS 5",
            "SYST:ERR?"
        ]
    );
    assert_eq!(second.last().map(String::as_str), Some("SYST:ERR?"));
    assert_eq!(second[second.len() - 2], "OUTP1 OFF");
}

#[test]
fn a_connection_refused_is_a_clear_error() {
    // A port that was free a moment ago: nothing listens there.
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let e = Instrument::connect(&config(InstrumentKind::Keysight33500b, port))
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with(&format!(
            "cannot reach the instrument at 127.0.0.1:{port}: "
        )),
        "{e}"
    );
}

#[test]
fn a_stopped_sequence_leaves_the_output_off() {
    let sim = SimInstrument::start(Faults::default()).unwrap();
    let cfg = config(InstrumentKind::Keysight33500b, sim.port());
    let mut inst = Instrument::connect(&cfg).unwrap();
    let long = Sequence {
        on_s: 30.0,
        off_s: 1.0,
        pwm_s: 1.0,
    };
    let steps = case_steps(&cfg, &case(90.0, 0.1), &long);
    let t = Instant::now();
    let stop = || t.elapsed().as_secs_f64() > 0.2;
    let e = sequence::run(&mut inst, &steps, t, &stop).unwrap_err();
    assert!(matches!(e, sequence::SequenceError::Stopped), "{e}");
    assert!(t.elapsed().as_secs_f64() < 5.0);
    let lines = sim.lines();
    assert_eq!(lines[lines.len() - 2..], ["OUTP1 OFF", "SYST:ERR?"]);
    assert!(lines.iter().any(|l| l == "OUTP1 ON"));
}

#[test]
fn error_answers_and_numbers_are_read_and_written_as_scpi_has_them() {
    assert_eq!(parse_error("+0,\"No error\""), Some((0, "No error".into())));
    assert_eq!(
        parse_error("-222,\"Data out of range\"\r"),
        Some((-222, "Data out of range".into()))
    );
    assert_eq!(parse_error("0"), Some((0, String::new())));
    assert_eq!(parse_error("No error"), None);
    assert_eq!(scpi_number(90.0), "90");
    assert_eq!(scpi_number(0.1 * 100.0), "10");
    assert_eq!(scpi_number(12.5), "12.5");
    assert_eq!(scpi_number(-0.0), "0");
    assert_eq!(scpi_number(1e-7), "0");
}
