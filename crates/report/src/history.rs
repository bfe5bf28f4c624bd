//! The browsable history of `ledflicker history --html FILE`: one
//! standalone HTML page (no server, no script) of the runs in the results
//! database, by camera and firmware, each linked to its report, with a
//! trend chart per plan and camera (docs/campaigns.md).

use minijinja::value::{Serde, Value};
use minijinja::{Environment, UndefinedBehavior};
use serde::Serialize;

use super::ReportError;
use super::charts::{TrendSeries, trend_svg};

const BASE: &str = include_str!("../../../templates/base.html.j2");
const PAGE: &str = include_str!("../../../templates/history.html.j2");

/// One run as the page lists it.
#[derive(Debug, Clone, Serialize)]
pub struct HistoryRun {
    /// Run id.
    pub id: i64,
    /// Report date, `YYYY-MM-DD`.
    pub date: String,
    /// Plan id.
    pub plan: String,
    /// `[dut]` serial and firmware.
    pub serial: String,
    /// See `serial`.
    pub firmware: String,
    /// `pass`, `fail` or `info`.
    pub verdict: String,
    /// Cases: total, pass, fail, not judged.
    pub cases: [i64; 4],
    /// `unsigned`, `signed`, `intact`, `broken` or `unchecked`.
    pub signature: String,
    /// The report directory as recorded.
    pub report_dir: String,
    /// Links to its report.html and report.pdf, when they exist now:
    /// percent-encoded URLs (no character HTML would read), written as
    /// they are.
    pub html_href: Option<String>,
    /// See `html_href`.
    pub pdf_href: Option<String>,
}

/// The runs of one camera.
#[derive(Debug, Clone, Serialize)]
pub struct CameraGroup {
    /// `[dut] supplier` and model.
    pub supplier: String,
    /// See `supplier`.
    pub camera: String,
    /// Its firmware versions, in the order first recorded.
    pub firmware: Vec<String>,
    /// Its runs, oldest first.
    pub runs: Vec<HistoryRun>,
}

/// A trend chart of the page.
#[derive(Debug, Clone)]
pub struct TrendChart {
    /// Heading and chart title.
    pub title: String,
    /// Y axis.
    pub y_desc: String,
    /// One label a run along x.
    pub labels: Vec<String>,
    /// The lines.
    pub series: Vec<TrendSeries>,
}

/// The whole page.
#[derive(Debug, Clone, Serialize)]
pub struct HistoryView {
    /// The results database file.
    pub database: String,
    /// The filters applied, in words (empty: none).
    pub filters: String,
    /// Date written, `YYYY-MM-DD`.
    pub date: String,
    /// Runs listed.
    pub runs: usize,
    /// By camera.
    pub cameras: Vec<CameraGroup>,
    /// Trend charts (drawn when the page is rendered).
    #[serde(skip)]
    pub charts: Vec<TrendChart>,
}

/// The page as HTML, charts inline.
pub fn html(view: &HistoryView) -> Result<String, ReportError> {
    let mut env = Environment::new();
    env.set_undefined_behavior(UndefinedBehavior::Strict);
    let err = |e: minijinja::Error| ReportError::Template {
        template: "history.html.j2".to_string(),
        message: format!("{e:#}"),
    };
    env.add_template("base.html.j2", BASE).map_err(err)?;
    env.add_template("history.html.j2", PAGE).map_err(err)?;
    let mut charts = Vec::new();
    for c in &view.charts {
        let svg = trend_svg(
            &c.title,
            ("firmware, oldest run first", &c.y_desc),
            &c.labels,
            &c.series,
            &[],
        )?;
        charts.push(minijinja::context! {
            title => c.title.clone(),
            svg => Value::from_safe_string(svg),
        });
    }
    env.get_template("history.html.j2")
        .and_then(|t| t.render(minijinja::context! { v => Serde(view), charts => charts }))
        .map_err(err)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_page_links_each_report_and_escapes_what_it_shows() {
        let run = |id: i64, firmware: &str, href: Option<&str>| HistoryRun {
            id,
            date: "2026-01-01".to_string(),
            plan: "daylight".to_string(),
            serial: "S".to_string(),
            firmware: firmware.to_string(),
            verdict: "pass".to_string(),
            cases: [4, 4, 0, 0],
            signature: "unsigned".to_string(),
            report_dir: "/r".to_string(),
            html_href: href.map(str::to_string),
            pdf_href: None,
        };
        let view = HistoryView {
            database: "/db.sqlite".to_string(),
            filters: String::new(),
            date: "2026-01-02".to_string(),
            runs: 2,
            cameras: vec![CameraGroup {
                supplier: "S".to_string(),
                camera: "EX-1 <new>".to_string(),
                firmware: vec!["1.0".to_string(), "1.1".to_string()],
                runs: vec![
                    run(1, "1.0", Some("file:///r/a/report.html")),
                    run(2, "1.1", None),
                ],
            }],
            charts: vec![TrendChart {
                title: "daylight on EX-1".to_string(),
                y_desc: "cases".to_string(),
                labels: vec!["1.0".to_string(), "1.1".to_string()],
                series: vec![("failing".to_string(), vec![Some(0.0), Some(1.0)])],
            }],
        };
        let page = html(&view).unwrap();
        assert!(page.contains("href=\"file:///r/a/report.html\""), "{page}");
        assert!(page.contains("EX-1 &lt;new&gt;"));
        assert!(page.contains("<svg"));
        assert!(page.contains("no report.html"), "a missing report says so");
        assert!(!page.contains("<script"), "the page runs no script");
    }
}
