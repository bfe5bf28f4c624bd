//! `ledflicker man [COMMAND [SUBCOMMAND]]`: the manual pages, clap's
//! NAME, SYNOPSIS, DESCRIPTION and OPTIONS followed by the sections a
//! manual page is read for: EXIT STATUS (from [`ExitCode`], so the page
//! and the numbers cannot differ), ENVIRONMENT, FILES and EXAMPLES.

use super::output::Stdout;
use super::{ExitCode, Failure, UsageError};

/// Each subcommand's examples, by its path (`rig check`); every
/// subcommand has an entry (a test walks the command tree).
const EXAMPLES: &[(&str, &[&str])] = &[
    (
        "",
        &[
            "ledflicker plan daylight",
            "ledflicker plans",
            "ledflicker man plan",
        ],
    ),
    (
        "export",
        &[
            "ledflicker export reports/sweep-23k --case 2000lux-55hz-10pct",
            "ledflicker export reports/sweep-23k --case 40lux-50hz-5pct --out one-case",
        ],
    ),
    (
        "plan",
        &[
            "ledflicker plan daylight --out reports/daylight",
            "ledflicker plan my-camera.toml --out reports/fw-1.1 --db results.sqlite -q",
            "ledflicker plan sweep-23k --shard 1/4 --out shards/1",
        ],
    ),
    (
        "merge",
        &["ledflicker merge shards/1 shards/2 shards/3 shards/4 --out reports/sweep"],
    ),
    (
        "plans",
        &[
            "ledflicker plans",
            "ledflicker plans show daylight > my-camera.toml",
        ],
    ),
    (
        "plans show",
        &["ledflicker plans show lowlight > lowlight.toml"],
    ),
    ("validate", &["ledflicker validate my-camera.toml"]),
    (
        "simulate",
        &[
            "ledflicker simulate --frequency-hz 90 --duty 0.2 --exposure-ms 11.111 --fps 30 --summary",
        ],
    ),
    (
        "advise",
        &["ledflicker advise --min-hz 90 --max-hz 2000 --min-duty 0.05 --fps 30"],
    ),
    (
        "bench",
        &["ledflicker bench", "ledflicker bench --end-to-end"],
    ),
    (
        "linetime",
        &["ledflicker linetime frames/*.png --frequency-hz 1000"],
    ),
    (
        "render",
        &["ledflicker render --frequency-hz 90 --duty 0.2 --exposure-ms 5 --fps 30 --out frames"],
    ),
    (
        "rig",
        &[
            "ledflicker rig check bench.toml",
            "ledflicker rig simulate --port 5025",
        ],
    ),
    ("rig check", &["ledflicker rig check bench.toml"]),
    ("rig simulate", &["ledflicker rig simulate --port 5025"]),
    (
        "roi",
        &[
            "ledflicker roi p2020-samples --out roi",
            "ledflicker roi --detect capture.mp4",
        ],
    ),
    (
        "bands",
        &["ledflicker bands frame.png --line-time-us 14.565"],
    ),
    (
        "calibrate",
        &["ledflicker calibrate frame.png --frequency-hz 1000 --out camera.toml"],
    ),
    (
        "light",
        &[
            "ledflicker light scope.csv",
            "ledflicker light scope.csv --json --bandwidth none",
        ],
    ),
    (
        "keygen",
        &[
            "ledflicker keygen --signer 'A. Engineer, Test lead' --org 'Example Optics' --out signer.key",
        ],
    ),
    (
        "sign",
        &["ledflicker sign reports/daylight --key signer.key --signer 'A. Engineer, Test lead'"],
    ),
    (
        "verify",
        &["ledflicker verify reports/daylight --trust signer.crt"],
    ),
    (
        "import",
        &["ledflicker import reports/old-run --db results.sqlite"],
    ),
    (
        "history",
        &[
            "ledflicker history --db results.sqlite",
            "ledflicker history --html history.html",
        ],
    ),
    (
        "compare",
        &[
            "ledflicker compare reports/fw-1.0 reports/fw-1.1 --junit compare.xml --report reports/compare",
        ],
    ),
    (
        "trend",
        &["ledflicker trend --kpi fdi_2018 --case 2000lux-90hz-5pct --svg trend.svg"],
    ),
    (
        "completions",
        &["ledflicker completions bash > ~/.local/share/bash-completion/completions/ledflicker"],
    ),
    (
        "man",
        &[
            "ledflicker man | man -l -",
            "ledflicker man rig check | man -l -",
        ],
    ),
];

/// Roff text: a backslash and a hyphen written so that roff prints them.
fn roff(text: &str) -> String {
    text.replace('\\', "\\e").replace('-', "\\-")
}

fn exit_status() -> String {
    let mut s = String::from(".SH \"EXIT STATUS\"\n");
    for code in ExitCode::ALL {
        s.push_str(&format!(
            ".TP\n\\fB{}\\fR\n{}\n",
            code.code(),
            roff(code.meaning())
        ));
    }
    let signal = ExitCode::Signal(2);
    s.push_str(&format!(
        ".TP\n\\fB130\\fR, \\fB143\\fR\n{}\n",
        roff(signal.meaning())
    ));
    s
}

fn environment() -> String {
    let vars = [
        (
            crate::campaign::ENV,
            "the results database: a file, or a postgres:// URL (overridden by \\-\\-db)",
        ),
        (
            "XDG_DATA_HOME",
            "an absolute path: the default results database is $XDG_DATA_HOME/ledflicker/results.sqlite",
        ),
        (
            "HOME",
            "without XDG_DATA_HOME, the default results database is ~/.local/share/ledflicker/results.sqlite",
        ),
        (
            "SOURCE_DATE_EPOCH",
            "the report date when \\-\\-date is not given (reproducible builds of a report)",
        ),
        (
            crate::plan::source::ADDRESS_ENV,
            "host:port of a plan's [source] instrument, replacing the plan's",
        ),
    ];
    let mut s = String::from(".SH ENVIRONMENT\n");
    for (name, what) in vars {
        s.push_str(&format!(".TP\n\\fB{}\\fR\n{what}\n", roff(name)));
    }
    s
}

fn files() -> String {
    let entries = [
        (
            "test\\-plans/NAME.toml",
            "a plan named without a path is looked up here, then among the built-in plans (ledflicker plans)",
        ),
        (
            "OUT/results.json",
            "every number of the run (schema in its \"schema\" field); report.html, report.pdf, junit.xml, summary.csv, traces/, charts/ and frames/ beside it",
        ),
        (
            "OUT/cases.sqlite",
            "every case of the run, as it finished; plan \\-\\-resume OUT continues from it",
        ),
        (
            "OUT/manifest.txt, OUT/signoff.p7s",
            "the sign\\-off of a signed report (ledflicker verify)",
        ),
        (
            "~/.local/share/ledflicker/results.sqlite",
            "the default results database (history, compare, trend)",
        ),
    ];
    let mut s = String::from(".SH FILES\n");
    for (path, what) in entries {
        s.push_str(&format!(".TP\n\\fI{path}\\fR\n{what}\n"));
    }
    s
}

fn examples(path: &str) -> String {
    let lines = EXAMPLES
        .iter()
        .find(|(p, _)| *p == path)
        .map_or(&[][..], |(_, l)| *l);
    let mut s = String::from(".SH EXAMPLES\n");
    for line in lines {
        s.push_str(&format!(".nf\n{}\n.fi\n", roff(line)));
    }
    s
}

/// The page of `ledflicker` itself (no `names`), or of the subcommand
/// `names` leads to (`rig check`), in roff.
pub(super) fn page(root: clap::Command, names: &[String]) -> Result<Vec<u8>, Failure> {
    let mut cmd = root;
    cmd.build();
    for name in names {
        let Some(sub) = cmd.find_subcommand(name).cloned() else {
            let list: Vec<&str> = cmd
                .get_subcommands()
                .map(|c| c.get_name())
                .filter(|n| *n != "help")
                .collect();
            return Err(UsageError(format!(
                "no subcommand `{name}` of `{}`\n    hint: one of {}",
                cmd.get_name(),
                list.join(", ")
            ))
            .into());
        };
        cmd = sub;
    }
    if !names.is_empty() {
        cmd = cmd.name(format!("ledflicker-{}", names.join("-")));
    }
    let mut out = Vec::new();
    clap_mangen::Man::new(cmd).render(&mut out)?;
    for section in [
        exit_status(),
        environment(),
        files(),
        examples(&names.join(" ")),
    ] {
        out.extend_from_slice(section.as_bytes());
    }
    Ok(out)
}

/// `ledflicker man`.
pub(super) fn man(root: clap::Command, names: &[String]) -> Result<ExitCode, Failure> {
    let page = page(root, names)?;
    std::io::Write::write_all(&mut Stdout, &page)?;
    Ok(ExitCode::Pass)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every subcommand, nested ones included, as its path.
    fn paths(cmd: &clap::Command, prefix: &str, out: &mut Vec<String>) {
        for sub in cmd.get_subcommands().filter(|c| c.get_name() != "help") {
            let path = format!("{prefix}{}", sub.get_name()).trim().to_string();
            out.push(path.clone());
            paths(sub, &format!("{path} "), out);
        }
    }

    #[test]
    fn every_page_has_exit_status_environment_files_and_its_own_examples() {
        let root = super::super::command("test");
        let mut all = vec![String::new()];
        paths(&root, "", &mut all);
        assert!(all.iter().any(|p| p == "rig check"), "{all:?}");
        for path in &all {
            let names: Vec<String> = path.split_whitespace().map(str::to_string).collect();
            let page = String::from_utf8(page(root.clone(), &names).unwrap()).unwrap();
            for section in [
                ".SH \"EXIT STATUS\"",
                ".SH ENVIRONMENT",
                ".SH FILES",
                ".SH EXAMPLES",
            ] {
                assert!(page.contains(section), "`{path}` lacks {section}");
            }
            let examples = &page[page.find(".SH EXAMPLES").unwrap()..];
            let head = roff(format!("ledflicker {path}").trim());
            assert!(
                examples.contains(&head),
                "`{path}` has no example of itself: {examples}"
            );
        }
        // Every entry of the table is a real subcommand.
        for (p, _) in EXAMPLES {
            assert!(all.iter().any(|a| a == p), "`{p}` is no subcommand");
        }
    }
}
