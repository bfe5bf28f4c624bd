//! The report profile in the report: its fields for the templates, and its
//! files (logo, replaced templates), which the report directory keeps under
//! `profile/` so that a report rendered again from its directory
//! (`ledflicker sign`) looks as it was written.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use minijinja::Value;

use super::{Document, ReportError};
use crate::model::{LABELS, ProfileMeta, ReportProfile, Results, SECTIONS};

/// Folder of the profile's files, relative to the report directory.
pub const PROFILE_DIR: &str = "profile";

/// A template that replaces a built-in one.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TemplateSource {
    /// Where it was read from, for error messages.
    pub path: PathBuf,
    /// Its text.
    pub text: String,
}

/// The profile's files a renderer needs.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Look {
    /// The logo: its path relative to the report directory, and its bytes.
    pub logo: Option<(String, Vec<u8>)>,
    /// Template name -> the template replacing the built-in one.
    pub templates: BTreeMap<String, TemplateSource>,
}

fn logo_path(format: &str) -> String {
    format!("{PROFILE_DIR}/logo.{format}")
}

fn template_path(name: &str) -> String {
    format!("{PROFILE_DIR}/templates/{name}")
}

/// results.json's `report.profile` of `profile`; `None` without one.
pub fn meta(profile: &ReportProfile) -> Option<ProfileMeta> {
    if profile.is_default() {
        return None;
    }
    Some(ProfileMeta {
        company: profile.company.clone(),
        document_number: profile.document_number.clone(),
        logo: profile.logo.as_ref().map(|l| logo_path(l.format)),
        labels: profile.labels.clone(),
        sections: profile.sections.clone(),
        templates: profile
            .templates
            .as_ref()
            .map(|t| t.sources.keys().cloned().collect())
            .unwrap_or_default(),
    })
}

/// Writes the profile's logo and templates into `dir/profile/` (and
/// removes an earlier report's); nothing without them.
pub fn write_files(dir: &Path, profile: &ReportProfile) -> Result<(), ReportError> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| ReportError::Io { path, source }
    };
    let root = dir.join(PROFILE_DIR);
    if root.exists() {
        std::fs::remove_dir_all(&root).map_err(io(&root))?;
    }
    let mut files: Vec<(String, &[u8])> = Vec::new();
    if let Some(logo) = &profile.logo {
        files.push((logo_path(logo.format), &logo.bytes));
    }
    for (name, text) in profile.templates.iter().flat_map(|t| &t.sources) {
        files.push((template_path(name), text.as_bytes()));
    }
    for (rel, bytes) in files {
        let path = dir.join(rel);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).map_err(io(parent))?;
        }
        crate::util::write_atomic(&path, bytes).map_err(io(&path))?;
    }
    Ok(())
}

impl Look {
    /// The profile's files as `profile` holds them (read at validation).
    pub fn of(profile: &ReportProfile) -> Look {
        Look {
            logo: profile
                .logo
                .as_ref()
                .map(|l| (logo_path(l.format), l.bytes.clone())),
            templates: profile
                .templates
                .iter()
                .flat_map(|t| {
                    t.sources.iter().map(|(name, text)| {
                        let source = TemplateSource {
                            path: t.dir.join(name),
                            text: text.clone(),
                        };
                        (name.clone(), source)
                    })
                })
                .collect(),
        }
    }

    /// The profile's files of the report in `dir`, as results.json's
    /// `report.profile` names them.
    pub fn load(dir: &Path, results: &Results) -> Result<Look, ReportError> {
        let Some(meta) = results.report.as_ref().and_then(|r| r.profile.as_ref()) else {
            return Ok(Look::default());
        };
        let read = |rel: &str| {
            let path = dir.join(rel);
            crate::util::read_input(&path).map_err(|source| ReportError::Io { path, source })
        };
        let logo = match &meta.logo {
            Some(rel) => Some((rel.clone(), read(rel)?)),
            None => None,
        };
        let mut templates = BTreeMap::new();
        for name in &meta.templates {
            let rel = template_path(name);
            let path = dir.join(&rel);
            let text = String::from_utf8(read(&rel)?).map_err(|_| ReportError::Invalid {
                path: path.clone(),
                message: "the template is not UTF-8 text".to_string(),
            })?;
            templates.insert(name.clone(), TemplateSource { path, text });
        }
        Ok(Look { logo, templates })
    }
}

impl Document {
    /// This document with the files of `profile` (logo, templates).
    pub fn with_profile_files(mut self, profile: &ReportProfile) -> Document {
        self.look = Look::of(profile);
        self
    }

    /// results.json's `report.profile`, or the default (no profile).
    pub fn profile(&self) -> ProfileMeta {
        self.results
            .report
            .as_ref()
            .and_then(|r| r.profile.clone())
            .unwrap_or_default()
    }

    /// The sections shown ([`SECTIONS`] without a profile's choice).
    pub fn sections(&self) -> Vec<String> {
        self.profile()
            .sections
            .unwrap_or_else(|| SECTIONS.iter().map(|s| s.to_string()).collect())
    }

    /// Every label key ([`LABELS`], `-` as `_`) -> the profile's text, or
    /// "" where the template keeps its own word.
    pub fn labels(&self) -> BTreeMap<String, String> {
        let chosen = self.profile().labels;
        LABELS
            .iter()
            .map(|k| {
                let text = chosen.get(*k).cloned().unwrap_or_default();
                (k.replace('-', "_"), text)
            })
            .collect()
    }

    /// The HTML's numbered sections -> their number among those shown.
    pub fn section_numbers(&self) -> BTreeMap<String, usize> {
        const NUMBERED: [&str; 9] = [
            "summary",
            "matrices",
            "driver",
            "verdicts",
            "cases",
            "method",
            "notes",
            "environment",
            "signoff",
        ];
        let shown = self.sections();
        // The driver's view exists only for a plan with `[display]`; the
        // other plans' sections keep their numbers.
        let display = self.results.display.is_some();
        NUMBERED
            .iter()
            .filter(|s| **s != "driver" || display)
            .filter(|s| shown.iter().any(|n| n == *s))
            .enumerate()
            .map(|(i, s)| (s.to_string(), i + 1))
            .collect()
    }

    /// The profile's fields every template gets: `sections`, `labels`,
    /// `numbers` and `look` (`company`, `document_number`, `logo`: what
    /// `logo` makes of the logo's path and bytes, or none).
    pub fn look_context(&self, logo: impl Fn(&str, &[u8]) -> Value) -> Value {
        let p = self.profile();
        let logo = self
            .look
            .logo
            .as_ref()
            .map_or(Value::from(()), |(path, bytes)| logo(path, bytes));
        minijinja::context! {
            sections => self.sections(),
            labels => self.labels(),
            numbers => self.section_numbers(),
            company => p.company.unwrap_or_default(),
            document_number => p.document_number.unwrap_or_default(),
            logo => logo,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Logo, TemplateOverrides};

    #[test]
    fn a_report_directory_keeps_the_look_it_was_written_with() {
        let dir = std::env::temp_dir().join(format!("ledflicker-look-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let profile = ReportProfile {
            company: Some("Acme".to_string()),
            logo: Some(Logo {
                path: PathBuf::from("logo.png"),
                format: "png",
                bytes: b"\x89PNG\r\n\x1a\nrest".to_vec(),
            }),
            templates: Some(TemplateOverrides {
                dir: PathBuf::from("mine"),
                sources: [("report.typ.j2".to_string(), "= Mine".to_string())].into(),
            }),
            ..ReportProfile::default()
        };
        write_files(&dir, &profile).unwrap();
        let (_, mut model) = super::super::small_run();
        model.report = Some(crate::model::ReportMeta {
            date: "2026-01-01".to_string(),
            detail: "standard".to_string(),
            inputs: Vec::new(),
            notes: Vec::new(),
            profile: meta(&profile),
        });
        let look = Look::load(&dir, &model).unwrap();
        let written = Look::of(&profile);
        assert_eq!(look.logo, written.logo);
        assert_eq!(look.templates["report.typ.j2"].text, "= Mine");
        assert_eq!(
            look.templates["report.typ.j2"].path,
            dir.join("profile/templates/report.typ.j2")
        );
        // Without a profile nothing is written, and an earlier one goes.
        write_files(&dir, &ReportProfile::default()).unwrap();
        assert!(!dir.join(PROFILE_DIR).exists());
        assert_eq!(meta(&ReportProfile::default()), None);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
