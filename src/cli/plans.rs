//! `ledflicker plans`: the plans built into the binary, listed, and one
//! written out as TOML to start a plan of one's own from.

use clap::{Args, Subcommand};

use super::output::{out, outln};
use super::{ExitCode, Failure, UsageError};
use crate::plan::shipped::{self, Shipped};

/// `ledflicker plans` arguments.
#[derive(Args, Debug)]
pub(super) struct PlansArgs {
    #[command(subcommand)]
    command: Option<PlansCommand>,
}

#[derive(Subcommand, Debug)]
enum PlansCommand {
    /// Print a built-in plan's TOML, e.g. `ledflicker plans show daylight >
    /// my-camera.toml`, to edit and run as a file.
    Show {
        /// The plan's name, as `ledflicker plans` lists it.
        name: String,
    },
}

/// A plan's name: its file name without `.toml`.
fn name(p: &Shipped) -> &'static str {
    let file = p.path.rsplit('/').next().unwrap_or(p.path);
    file.strip_suffix(".toml").unwrap_or(file)
}

/// A plan's first sentence, from the comment it opens with.
fn summary(p: &Shipped) -> String {
    let text: Vec<&str> = p
        .text
        .lines()
        .map_while(|l| l.strip_prefix('#'))
        .map(str::trim)
        .take_while(|l| !l.is_empty())
        .collect();
    let text = text.join(" ");
    let end = [". ", "? ", ": "]
        .iter()
        .filter_map(|stop| text.find(stop).map(|i| i + stop.len() - 1))
        .min()
        .unwrap_or(text.len());
    let sentence = text[..end].trim_end_matches([':', ' ']);
    // One line of a listing: a long sentence is cut at a word.
    if sentence.chars().count() <= SUMMARY_CHARS {
        return sentence.to_string();
    }
    let cut: String = sentence.chars().take(SUMMARY_CHARS).collect();
    let at = cut.rfind(' ').unwrap_or(cut.len());
    format!("{}...", cut[..at].trim_end_matches([',', ' ']))
}

/// Longest summary a listing line shows, in characters.
const SUMMARY_CHARS: usize = 90;

pub(super) fn plans(args: PlansArgs) -> Result<ExitCode, Failure> {
    match args.command {
        None => {
            let width = shipped::PLANS
                .iter()
                .map(|p| name(p).len())
                .max()
                .unwrap_or(0);
            for p in shipped::PLANS {
                outln!("{:width$}  {}", name(p), summary(p))?;
            }
            Ok(ExitCode::Pass)
        }
        Some(PlansCommand::Show { name: wanted }) => {
            let Some(p) = shipped::plan(&wanted) else {
                let names: Vec<&str> = shipped::PLANS.iter().map(name).collect();
                return Err(UsageError(format!(
                    "no built-in plan `{wanted}`\n    hint: one of {}",
                    names.join(", ")
                ))
                .into());
            };
            out!("{}", p.text)?;
            Ok(ExitCode::Pass)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_plan_has_a_name_and_a_one_line_summary() {
        for p in shipped::PLANS {
            let s = summary(p);
            assert!(!name(p).is_empty() && !name(p).contains('/'), "{}", p.path);
            assert!(
                (10..=SUMMARY_CHARS + 3).contains(&s.chars().count()),
                "{}: {s:?}",
                p.path
            );
            assert!(!s.contains('\n') && !s.starts_with('#'), "{s:?}");
        }
        let daylight = shipped::plan("daylight").unwrap();
        assert_eq!(
            summary(daylight),
            "Daylight LED flicker test after Deegan 2018 (IS&T EI AVM-146), section 3"
        );
    }
}
