//! `[source]`: the light source a command plan drives over SCPI, a
//! function generator or LED driver on the lab network, and the command
//! templates that set it (docs/lab.md).
//!
//! A template is plain data: the SCPI lines for each action, with
//! placeholders filled per case. The built-in templates follow the
//! vendors' programming manuals (cited in docs/lab.md); a plan may replace
//! any of their lines under `[source.commands]`, or give all of them with
//! `instrument = "custom"`.

/// Default TCP port of an LXI instrument's raw SCPI socket.
pub const DEFAULT_PORT: u16 = 5025;

/// Placeholders a command line may hold, each replaced by a number (or
/// the channel) when the line is sent.
pub const PLACEHOLDERS: &[&str] = &[
    "channel",
    "frequency-hz",
    "duty-percent",
    "amplitude-vpp",
    "offset-v",
    "high-v",
    "low-v",
];

/// A built-in instrument template, or the plan's own.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InstrumentKind {
    /// Keysight 33500B series (33509B..33622A), SCPI.
    Keysight33500b,
    /// Rigol DG1000Z series (DG1022Z, DG1032Z, DG1062Z), SCPI.
    RigolDg1000z,
    /// Siglent SDG series (SDG1000X, SDG2000X, SDG6000X), Siglent's
    /// `C<n>:BSWV` command set.
    SiglentSdg,
    /// Every command given in `[source.commands]`.
    Custom,
}

impl InstrumentKind {
    /// The names a plan gives `[source] instrument`, with their kinds.
    pub const NAMES: &[(&'static str, InstrumentKind)] = &[
        ("keysight-33500b", InstrumentKind::Keysight33500b),
        ("rigol-dg1000z", InstrumentKind::RigolDg1000z),
        ("siglent-sdg", InstrumentKind::SiglentSdg),
        ("custom", InstrumentKind::Custom),
    ];

    /// The plan's name of this kind, e.g. "keysight-33500b".
    pub fn name(self) -> &'static str {
        Self::NAMES
            .iter()
            .find(|(_, k)| *k == self)
            .map_or("custom", |(n, _)| n)
    }

    /// The built-in template; `None` for [`InstrumentKind::Custom`].
    pub fn template(self) -> Option<CommandSet> {
        let lines = |l: &[&str]| l.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        let set = match self {
            // Keysight 33500B Series Operating and Service Guide: SOURce,
            // FUNCtion:SQUare:DCYCle, VOLTage:OFFSet, OUTPut[1|2]:LOAD,
            // OUTPut[1|2]; the DC function's level is its offset.
            Self::Keysight33500b => CommandSet {
                identify: "*IDN?".into(),
                error_query: "SYST:ERR?".into(),
                setup: lines(&["*CLS", "OUTP{channel}:LOAD INF"]),
                steady: lines(&["SOUR{channel}:FUNC DC", "SOUR{channel}:VOLT:OFFS {high-v}"]),
                pwm: lines(&[
                    "SOUR{channel}:FUNC SQU",
                    "SOUR{channel}:FREQ {frequency-hz}",
                    "SOUR{channel}:VOLT {amplitude-vpp}",
                    "SOUR{channel}:VOLT:OFFS {offset-v}",
                    "SOUR{channel}:FUNC:SQU:DCYC {duty-percent}",
                ]),
                output_on: lines(&["OUTP{channel} ON"]),
                output_off: lines(&["OUTP{channel} OFF"]),
            },
            // RIGOL DG1000Z Programming Guide: [:SOURce[<n>]] subsystem,
            // :FUNCtion:SQUare:DCYCle, :OUTPut[<n>][:STATe],
            // :OUTPut[<n>]:IMPedance, :SYSTem:ERRor?.
            Self::RigolDg1000z => CommandSet {
                identify: "*IDN?".into(),
                error_query: ":SYST:ERR?".into(),
                setup: lines(&["*CLS", ":OUTP{channel}:IMP INF"]),
                steady: lines(&[
                    ":SOUR{channel}:FUNC DC",
                    ":SOUR{channel}:VOLT:OFFS {high-v}",
                ]),
                pwm: lines(&[
                    ":SOUR{channel}:FUNC SQU",
                    ":SOUR{channel}:FREQ {frequency-hz}",
                    ":SOUR{channel}:VOLT {amplitude-vpp}",
                    ":SOUR{channel}:VOLT:OFFS {offset-v}",
                    ":SOUR{channel}:FUNC:SQU:DCYC {duty-percent}",
                ]),
                output_on: lines(&[":OUTP{channel} ON"]),
                output_off: lines(&[":OUTP{channel} OFF"]),
            },
            // Siglent SDG Series Programming Guide: BSWV (basic wave:
            // WVTP, FRQ, AMP, OFST, DUTY), OUTP (state and LOAD).
            Self::SiglentSdg => CommandSet {
                identify: "*IDN?".into(),
                error_query: "SYST:ERR?".into(),
                setup: lines(&["*CLS", "C{channel}:OUTP LOAD,HZ"]),
                steady: lines(&["C{channel}:BSWV WVTP,DC,OFST,{high-v}"]),
                pwm: lines(&[
                    "C{channel}:BSWV WVTP,SQUARE,FRQ,{frequency-hz},AMP,{amplitude-vpp},OFST,{offset-v},DUTY,{duty-percent}",
                ]),
                output_on: lines(&["C{channel}:OUTP ON"]),
                output_off: lines(&["C{channel}:OUTP OFF"]),
            },
            Self::Custom => return None,
        };
        Some(set)
    }
}

/// The SCPI lines of each action; placeholders in braces ([`PLACEHOLDERS`]).
#[derive(Debug, Clone, PartialEq)]
pub struct CommandSet {
    /// Identity query, answered with one line (`*IDN?`).
    pub identify: String,
    /// Error-queue query, answered `<code>,<message>` with code 0 when the
    /// queue is empty; empty: the instrument has none, nothing is checked.
    pub error_query: String,
    /// Sent once after connecting (clear status, output load).
    pub setup: Vec<String>,
    /// Steady light, 100 % duty, at the high level (output state unchanged).
    pub steady: Vec<String>,
    /// The case's PWM square wave (output state unchanged).
    pub pwm: Vec<String>,
    /// Output on.
    pub output_on: Vec<String>,
    /// Output off: the safe state.
    pub output_off: Vec<String>,
}

/// `[source]`, validated.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceConfig {
    /// Which template the commands came from.
    pub instrument: InstrumentKind,
    /// Host name or IP address of the instrument.
    pub host: String,
    /// TCP port of its raw SCPI socket (1..=65535; LXI: 5025).
    pub port: u16,
    /// Output channel, 1..=16.
    pub channel: u32,
    /// PWM amplitude, volts peak to peak (> 0).
    pub amplitude_vpp: f64,
    /// PWM offset, volts; the low level is `offset - amplitude / 2`.
    pub offset_v: f64,
    /// Longest wait for a connection or an answer, seconds.
    pub timeout_s: f64,
    /// Dark time between starting the capture command and the ON step,
    /// seconds (>= 0): the camera is recording before the light changes.
    pub lead_in_s: f64,
    /// How often a dropped connection is reopened before the case fails.
    pub reconnects: u32,
    /// The commands, template and plan overrides merged.
    pub commands: CommandSet,
}

impl SourceConfig {
    /// The high level of the square wave, volts: the steady ON level.
    pub fn high_v(&self) -> f64 {
        self.offset_v + self.amplitude_vpp / 2.0
    }

    /// The low level of the square wave, volts.
    pub fn low_v(&self) -> f64 {
        self.offset_v - self.amplitude_vpp / 2.0
    }

    /// Points the source at `address` (`HOST:PORT`, the value of
    /// [`ADDRESS_ENV`]), for a plan that runs on another bench or against
    /// a simulator at a free port; the error names the variable.
    pub fn set_address(&mut self, address: &str) -> Result<(), String> {
        let bad = || {
            format!(
                "{ADDRESS_ENV}: `{address}` is not HOST:PORT\n    hint: e.g. 192.168.1.50:5025 or 127.0.0.1:5025, a port in 1..=65535"
            )
        };
        let (host, port) = address.rsplit_once(':').ok_or_else(bad)?;
        let port: u16 = port.parse().map_err(|_| bad())?;
        if host.is_empty() || port == 0 || host.contains(char::is_whitespace) || host.contains('/')
        {
            return Err(bad());
        }
        self.host = host.to_string();
        self.port = port;
        Ok(())
    }
}

/// Environment variable that, when set, gives the light source's address
/// (`HOST:PORT`) in place of the plan's `[source] host` and `port`: the
/// same plan on another bench, or against `ledflicker rig simulate` at a
/// free port. The address used is the one results.json records.
pub const ADDRESS_ENV: &str = "LEDFLICKER_SOURCE_ADDRESS";

#[cfg(test)]
mod tests {
    use super::*;

    /// A command plan with `source` as its `[source]` table(s).
    fn plan_with(source: &str) -> Result<crate::plan::Plan, String> {
        let text = format!(
            "[plan]\nid = \"s\"\ntitle = \"s\"\n[sequence]\non-s = 0.5\noff-s = 0.5\npwm-s = 2.0\n[light]\nlevels-lux = [2000.0]\n[grid]\nfrequencies-hz = [90.0]\nduty-cycles = [0.1]\n[[roi]]\nname = \"led\"\nx-px = 10\ny-px = 20\n[dut]\nbackend = \"command\"\n[capture]\ncommand = [\"true\"]\n{source}"
        );
        crate::plan::parse(&text, std::path::Path::new("s.toml"), String::new())
            .map_err(|e| e.to_string())
    }

    #[test]
    fn an_address_from_the_environment_replaces_host_and_port() {
        let plan =
            plan_with("[source]\ninstrument = \"keysight-33500b\"\nhost = \"10.0.0.7\"\n").unwrap();
        let mut s = plan.source.unwrap();
        s.set_address("127.0.0.1:40123").unwrap();
        assert_eq!((s.host.as_str(), s.port), ("127.0.0.1", 40123));
        for bad in ["127.0.0.1", "h:0", ":5025", "h:65536", "h:x", "a b:1"] {
            let e = s.set_address(bad).unwrap_err();
            assert!(
                e.starts_with(&format!(
                    "LEDFLICKER_SOURCE_ADDRESS: `{bad}` is not HOST:PORT"
                )),
                "{e}"
            );
        }
        assert_eq!((s.host.as_str(), s.port), ("127.0.0.1", 40123));
    }

    #[test]
    fn a_built_in_instrument_takes_its_template_and_the_defaults() {
        let plan = plan_with(
            "[source]\ninstrument = \"rigol-dg1000z\"\nhost = \"10.0.0.7\"\namplitude-vpp = 3.3\n",
        )
        .unwrap();
        let s = plan.source.unwrap();
        assert_eq!(s.port, DEFAULT_PORT);
        assert_eq!(s.channel, 1);
        assert!((s.offset_v - 1.65).abs() < 1e-12, "{}", s.offset_v);
        assert!(s.low_v().abs() < 1e-12);
        assert_eq!(s.commands, InstrumentKind::RigolDg1000z.template().unwrap());
    }

    #[test]
    fn plan_lines_replace_the_templates_own() {
        let plan = plan_with("[source]\ninstrument = \"keysight-33500b\"\nhost = \"h\"\n[source.commands]\npwm = [\"APPL:SQU {frequency-hz},{amplitude-vpp},{offset-v}\", \"FUNC:SQU:DCYC {duty-percent}\"]\n").unwrap();
        let s = plan.source.unwrap();
        assert_eq!(s.commands.pwm.len(), 2);
        assert_eq!(s.commands.output_on, ["OUTP{channel} ON"]);
    }

    #[test]
    fn source_mistakes_are_errors_at_their_keys() {
        let e = plan_with("[source]\ninstrument = \"custom\"\nhost = \"h\"\nport = 70000\n")
            .unwrap_err();
        assert!(
            e.contains("`source.port`: 70000 is outside 1..=65535"),
            "{e}"
        );
        assert!(
            e.contains("`source.commands`: a custom instrument needs its commands"),
            "{e}"
        );
        let e = plan_with("[source]\ninstrument = \"keysight-33500b\"\nhost = \"h\"\n[source.commands]\npwm = [\"FREQ {frequency}\"]\n").unwrap_err();
        assert!(
            e.contains("`source.commands.pwm[0]`: unknown placeholder `{frequency}`"),
            "{e}"
        );
        let e =
            plan_with("[source]\ninstrument = \"keysight-33500b\"\nhost = \"h\"\ntimeout-ms = 5\n")
                .unwrap_err();
        assert!(e.contains("`source.timeout-ms`: unknown key"), "{e}");
        assert!(e.contains("did you mean `timeout-s`?"), "{e}");
        let e = plan_with("[source]\ninstrument = \"agilent\"\nhost = \"h\"\n").unwrap_err();
        assert!(
            e.contains("`source.instrument`: unknown value `agilent`"),
            "{e}"
        );
    }

    #[test]
    fn only_a_command_plan_drives_a_source() {
        let text = "[plan]\nid = \"s\"\ntitle = \"s\"\n[light]\nlevels-lux = [2000.0]\n[grid]\nfrequencies-hz = [90.0]\nduty-cycles = [0.1]\n[dut.camera]\nshutter = \"global\"\nsensor-rows = 8\nsensor-columns = 8\nexposure-ms = 1.0\nframe-rate-fps = 30.0\nresponse-dn-per-cd-m2-s = 1.0\n[source]\ninstrument = \"siglent-sdg\"\nhost = \"h\"\n";
        let e = crate::plan::parse(text, std::path::Path::new("s.toml"), String::new())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("`source`: only the command backend drives a light source"),
            "{e}"
        );
    }
}
