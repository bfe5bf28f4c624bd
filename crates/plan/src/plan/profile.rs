//! The report's look: `[report]` of a plan, or a report profile file given
//! with `ledflicker plan --profile FILE` (the same keys under `[report]`),
//! whose keys win over the plan's one by one.
//!
//! Validated with the plan (`validate::report`), so a missing logo or
//! template folder fails `validate`, not the report stage. The files a
//! profile names are read here, once: the report writes them into its
//! directory (`profile/`), so that a report rendered again from its
//! directory (`ledflicker sign`) keeps its look. docs/plan-format.md,
//! "Report profile", documents the keys.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::check::Checker;
use super::raw::RawReportFile;
use super::spans::{SpanIndex, unknown_key_hint};
use super::{Diagnostic, PlanError};

/// The report's sections, in the order the report has them; `sections`
/// chooses among them (the order stays this one).
pub const SECTIONS: &[&str] = &[
    "summary",
    "matrices",
    "driver",
    "verdicts",
    "informational",
    "cases",
    "fine-maps",
    "advice",
    "method",
    "notes",
    "environment",
    "glossary",
    "signoff",
];

/// Sections every report has: a signed report states its verdict and
/// carries its sign-off, whatever the profile chooses.
pub const REQUIRED_SECTIONS: &[&str] = &["summary", "signoff"];

/// The cover and sign-off fields a profile may rename (`[report.labels]`).
pub const LABELS: &[&str] = &[
    "company",
    "document-number",
    "standard",
    "supplier",
    "model",
    "serial",
    "firmware",
    "lab",
    "date",
    "status",
    "signatory",
];

/// Templates a profile's `templates` folder may replace.
pub const TEMPLATE_NAMES: &[&str] = &["base.html.j2", "report.html.j2", "report.typ.j2"];

/// A logo for the cover and the page header.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Logo {
    /// Where it was read from.
    pub path: PathBuf,
    /// `png` or `svg`.
    pub format: &'static str,
    /// The file.
    pub bytes: Vec<u8>,
}

/// Templates that replace built-in ones, read from a profile's folder.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TemplateOverrides {
    /// The folder.
    pub dir: PathBuf,
    /// Template name ([`TEMPLATE_NAMES`]) -> its source, for the names the
    /// folder holds.
    pub sources: BTreeMap<String, String>,
}

/// The report's look. Every field is optional: the default is the report
/// as ledflicker writes it without a profile.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ReportProfile {
    /// Company name, on the cover and in the page header.
    pub company: Option<String>,
    /// Document number, on the cover and in the page header and footer.
    pub document_number: Option<String>,
    /// Logo, on the cover and in the page header.
    pub logo: Option<Logo>,
    /// Label key ([`LABELS`]) -> the text shown instead of the default.
    pub labels: BTreeMap<String, String>,
    /// The sections shown, a subset of [`SECTIONS`] holding
    /// [`REQUIRED_SECTIONS`]; `None`: every section.
    pub sections: Option<Vec<String>>,
    /// Templates replacing built-in ones.
    pub templates: Option<TemplateOverrides>,
}

impl ReportProfile {
    /// This profile with every key `over` sets taken from `over` (labels
    /// one by one).
    pub fn overridden_by(mut self, over: ReportProfile) -> ReportProfile {
        self.labels.extend(over.labels);
        ReportProfile {
            company: over.company.or(self.company),
            document_number: over.document_number.or(self.document_number),
            logo: over.logo.or(self.logo),
            labels: self.labels,
            sections: over.sections.or(self.sections),
            templates: over.templates.or(self.templates),
        }
    }

    /// Nothing set: the report looks as without a profile.
    pub fn is_default(&self) -> bool {
        *self == ReportProfile::default()
    }
}

/// Reads and validates a report profile file (`--profile FILE`): a TOML
/// file with a `[report]` table. Paths in it are relative to the file.
pub fn load_report_profile(path: &Path) -> Result<ReportProfile, PlanError> {
    let text = std::fs::read_to_string(path).map_err(|source| PlanError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let syntax = |e: toml::de::Error| PlanError::Syntax {
        path: path.to_path_buf(),
        message: super::spans::syntax_message(&text, &e),
    };
    let index = SpanIndex::build(&text).map_err(syntax)?;
    let de = toml::Deserializer::parse(&text).map_err(syntax)?;
    let mut unknown = Vec::new();
    let raw: RawReportFile =
        super::spans::deserialize_noting_unknown(de, &mut unknown).map_err(syntax)?;
    let mut diags: Vec<Diagnostic> = Vec::new();
    let mut warnings = Vec::new();
    let mut c = Checker::new(&index, &mut diags, &mut warnings);
    for key in unknown {
        let hint = unknown_key_hint(&key);
        c.error(&key, "unknown key", Some(&hint));
    }
    let profile = match raw.report {
        Some(r) => super::validate::report_table(&mut c, Some(r), path),
        None => {
            c.error(
                "report",
                "missing [report] table",
                Some("a report profile holds one [report] table with the keys of a plan's [report] (docs/plan-format.md)"),
            );
            None
        }
    };
    match profile {
        Some(p) if diags.is_empty() => Ok(p),
        _ => Err(PlanError::Invalid {
            path: path.to_path_buf(),
            diagnostics: diags,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::parse;

    fn repo(rel: &str) -> PathBuf {
        Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../..")).join(rel)
    }

    /// The small test plan with `report` appended, read as if it were the
    /// file `path`.
    fn plan_with(report: &str, path: &Path) -> Result<crate::plan::Plan, PlanError> {
        let base = std::fs::read_to_string(repo("tests/fixtures/plans/base.toml")).unwrap();
        parse(&format!("{base}\n{report}"), path, String::new())
    }

    fn diagnostics(e: PlanError) -> Vec<Diagnostic> {
        match e {
            PlanError::Invalid { diagnostics, .. } => diagnostics,
            other => panic!("not a validation error: {other}"),
        }
    }

    /// A fresh folder for one test.
    fn scratch(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("ledflicker-profile-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn no_report_table_is_the_default_look() {
        let p = plan_with("", &repo("tests/fixtures/plans/base.toml")).unwrap();
        assert!(p.report.is_default());
    }

    #[test]
    fn an_unknown_section_is_an_error_listing_the_names() {
        let e = plan_with(
            "[report]\nsections = [\"summary\", \"charts\", \"signoff\"]\n",
            Path::new("p.toml"),
        )
        .unwrap_err();
        let d = diagnostics(e);
        assert_eq!(d.len(), 1, "{d:?}");
        assert_eq!(d[0].key, "report.sections[1]");
        assert!(
            d[0].message.contains("unknown section `charts`"),
            "{}",
            d[0]
        );
        let hint = d[0].hint.as_deref().unwrap();
        for name in SECTIONS {
            assert!(hint.contains(name), "{hint}");
        }
    }

    #[test]
    fn sections_keep_the_summary_and_the_signoff_and_the_report_order() {
        let e = plan_with("[report]\nsections = [\"matrices\"]\n", Path::new("p.toml"));
        let d = diagnostics(e.unwrap_err());
        let messages: Vec<_> = d.iter().map(|d| d.message.as_str()).collect();
        assert_eq!(messages, ["lacks `summary`", "lacks `signoff`"]);
        assert!(d.iter().all(|d| d.key == "report.sections"));
        let p = plan_with(
            "[report]\nsections = [\"signoff\", \"method\", \"summary\"]\n",
            Path::new("p.toml"),
        )
        .unwrap();
        assert_eq!(
            p.report.sections.unwrap(),
            ["summary", "method", "signoff"],
            "listed in any order, shown in the report's"
        );
    }

    #[test]
    fn a_logo_is_checked_relative_to_the_file_that_names_it() {
        let dir = scratch("logo");
        let plan = dir.join("plan.toml");
        // Missing: the key and the file resolved next to the plan.
        let d = diagnostics(plan_with("[report]\nlogo = \"logo.png\"\n", &plan).unwrap_err());
        assert_eq!(d[0].key, "report.logo");
        assert!(
            d[0].message
                .contains(&dir.join("logo.png").display().to_string()),
            "{}",
            d[0]
        );
        // A .png that is not a PNG.
        std::fs::write(dir.join("logo.png"), "<svg></svg>").unwrap();
        let d = diagnostics(plan_with("[report]\nlogo = \"logo.png\"\n", &plan).unwrap_err());
        assert!(d[0].message.contains("is not a PNG picture"), "{}", d[0]);
        // Neither PNG nor SVG.
        let d = diagnostics(plan_with("[report]\nlogo = \"logo.jpg\"\n", &plan).unwrap_err());
        assert!(
            d[0].message.contains("is not a .png or .svg file"),
            "{}",
            d[0]
        );
        // An SVG is read whole.
        let svg = "<svg xmlns=\"http://www.w3.org/2000/svg\"/>";
        std::fs::write(dir.join("logo.svg"), svg).unwrap();
        let p = plan_with("[report]\nlogo = \"logo.svg\"\n", &plan).unwrap();
        let logo = p.report.logo.unwrap();
        assert_eq!(
            (logo.format, logo.bytes.as_slice()),
            ("svg", svg.as_bytes())
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn unknown_labels_and_keys_are_errors_with_their_names() {
        let d = diagnostics(
            plan_with(
                "[report]\ncompny = \"x\"\n[report.labels]\nprepared-for = \"x\"\n",
                Path::new("p.toml"),
            )
            .unwrap_err(),
        );
        let keys: Vec<_> = d.iter().map(|d| d.key.as_str()).collect();
        assert_eq!(
            keys,
            ["report.compny", "report.labels.prepared-for"],
            "{d:?}"
        );
        assert!(d[0].hint.as_deref().unwrap().contains("company"));
        assert!(d[1].hint.as_deref().unwrap().contains("document-number"));
    }

    #[test]
    fn a_template_folder_must_hold_a_template_of_the_report() {
        let dir = scratch("templates");
        std::fs::create_dir_all(dir.join("mine")).unwrap();
        let plan = dir.join("plan.toml");
        let d = diagnostics(plan_with("[report]\ntemplates = \"mine\"\n", &plan).unwrap_err());
        assert!(
            d[0].message.contains("holds no template of the report"),
            "{}",
            d[0]
        );
        let d = diagnostics(plan_with("[report]\ntemplates = \"none\"\n", &plan).unwrap_err());
        assert!(d[0].message.contains("does not exist"), "{}", d[0]);
        std::fs::write(dir.join("mine/report.typ.j2"), "x").unwrap();
        let p = plan_with("[report]\ntemplates = \"mine\"\n", &plan).unwrap();
        let t = p.report.templates.unwrap();
        assert_eq!(t.sources.keys().collect::<Vec<_>>(), ["report.typ.j2"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_profile_file_wins_over_the_plan_key_by_key() {
        let plan = plan_with(
            "[report]\ncompany = \"Plan Co\"\nsections = [\"summary\", \"signoff\"]\n\
             [report.labels]\nlab = \"Lab of the plan\"\nstatus = \"State\"\n",
            Path::new("p.toml"),
        )
        .unwrap();
        let profile = load_report_profile(&repo("test-plans/profiles/acme.toml")).unwrap();
        let look = plan.report.overridden_by(profile);
        assert_eq!(
            look.company.as_deref(),
            Some("Acme Automotive Cameras GmbH")
        );
        assert_eq!(look.document_number.as_deref(), Some("ACME-FLK-2026-0042"));
        assert_eq!(look.labels["lab"], "Test laboratory", "the profile's label");
        assert_eq!(
            look.labels["status"], "State",
            "the plan's, not in the profile"
        );
        assert_eq!(look.sections.unwrap().len(), 6);
        assert_eq!(look.logo.unwrap().format, "svg");
    }

    #[test]
    fn a_profile_file_without_a_report_table_names_the_file() {
        let dir = scratch("file");
        let path = dir.join("p.toml");
        std::fs::write(&path, "company = \"x\"\n").unwrap();
        let e = load_report_profile(&path).unwrap_err().to_string();
        assert!(e.contains(&path.display().to_string()), "{e}");
        assert!(e.contains("missing [report] table"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
