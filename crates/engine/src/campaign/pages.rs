//! The runs of the results database as the browsable history page shows
//! them ([`ledflicker_report::history::HistoryView`]): grouped by camera, each
//! linked to its report where it still is, with a chart of failing and
//! passing cases per run for each plan and camera.

use std::collections::BTreeMap;
use std::path::Path;

use super::query::RunRow;
use ledflicker_report::history::{CameraGroup, HistoryRun, HistoryView, TrendChart};

/// `path` as a `file://` URL: a page opened from disk follows it, and a
/// space, `#` or `?` in a directory name stays part of the path.
pub fn file_url(path: &Path) -> String {
    let mut url = String::from("file://");
    for b in path.to_string_lossy().bytes() {
        match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'/' | b'-' | b'_' | b'.' | b'~' => {
                url.push(b as char)
            }
            _ => url.push_str(&format!("%{b:02X}")),
        }
    }
    url
}

fn link(dir: &str, file: &str) -> Option<String> {
    let path = Path::new(dir).join(file);
    path.is_file().then(|| file_url(&path))
}

fn row(r: &RunRow) -> HistoryRun {
    HistoryRun {
        id: r.id,
        date: r.date.clone(),
        plan: r.plan_id.clone(),
        serial: r.serial.clone(),
        firmware: r.firmware.clone(),
        verdict: r.verdict.clone(),
        cases: r.cases,
        signature: r.signature.clone(),
        report_dir: r.report_dir.clone(),
        html_href: link(&r.report_dir, "report.html"),
        pdf_href: link(&r.report_dir, "report.pdf"),
    }
}

/// The page's view of `runs` (oldest first) of `database`, written on
/// `date`, with the filters in words.
pub fn history_view(runs: &[RunRow], database: &Path, filters: &str, date: &str) -> HistoryView {
    let mut cameras: Vec<CameraGroup> = Vec::new();
    for r in runs {
        let at = match cameras
            .iter()
            .position(|g| g.camera == r.model && g.supplier == r.supplier)
        {
            Some(at) => at,
            None => {
                cameras.push(CameraGroup {
                    supplier: r.supplier.clone(),
                    camera: r.model.clone(),
                    firmware: Vec::new(),
                    runs: Vec::new(),
                });
                cameras.len() - 1
            }
        };
        let g = &mut cameras[at];
        if !g.firmware.contains(&r.firmware) {
            g.firmware.push(r.firmware.clone());
        }
        g.runs.push(row(r));
    }
    let mut by_plan: BTreeMap<(&str, &str), Vec<&RunRow>> = BTreeMap::new();
    for r in runs {
        by_plan
            .entry((r.plan_id.as_str(), r.model.as_str()))
            .or_default()
            .push(r);
    }
    let charts = by_plan
        .into_iter()
        .filter(|(_, runs)| runs.len() >= 2)
        .map(|((plan, camera), runs)| TrendChart {
            title: format!("{plan} on {camera}"),
            y_desc: "cases".to_string(),
            labels: runs.iter().map(|r| r.firmware.clone()).collect(),
            // Passing in the first series colour (blue), failing in the
            // second (red).
            series: vec![
                (
                    "passing".to_string(),
                    runs.iter().map(|r| Some(r.cases[1] as f64)).collect(),
                ),
                (
                    "failing".to_string(),
                    runs.iter().map(|r| Some(r.cases[2] as f64)).collect(),
                ),
            ],
        })
        .collect();
    HistoryView {
        database: database.display().to_string(),
        filters: filters.to_string(),
        date: date.to_string(),
        runs: runs.len(),
        cameras,
        charts,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_url_escapes_what_a_url_would_read_otherwise() {
        assert_eq!(
            file_url(Path::new("/r/fw 1.1/#2?/report.html")),
            "file:///r/fw%201.1/%232%3F/report.html"
        );
        assert_eq!(file_url(Path::new("/a/ü")), "file:///a/%C3%BC");
    }
}
