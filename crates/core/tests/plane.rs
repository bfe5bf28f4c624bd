//! The results model's frequency x duty planes, on the model of a small
//! plan run on the simulator.

use ledflicker_core::model::plane::eq1_rows;
use ledflicker_core::model::{Results, read_results};

/// The small fixture plan (2 frequencies x 2 duties at 2000 lux, an
/// 11.111 ms exposure) run on the simulator.
fn small_model() -> Results {
    let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
        .join("tests/fixtures/plans/base.toml");
    let plan = ledflicker_core::plan::load(&path).unwrap();
    let cases = ledflicker_core::plan::expand_cases(&plan);
    let backend = ledflicker_core::backend::sim::Simulator::new(&plan);
    let results = ledflicker_core::runner::run(&plan, &cases, &backend, Some(2), &|_| {}).unwrap();
    ledflicker_core::model::assemble(&plan, "sim-ideal", &results)
}

#[test]
fn eq1_rows_follow_the_closed_form() {
    // T_exp = 11.111 ms: (1 - D) / f > T_exp below D = 1 - f T_exp:
    // 44.4 % at 50 Hz, 0 % from 90 Hz.
    let rows = eq1_rows(
        &[50.0, 90.0, 1000.0],
        &[5.0, 10.0, 20.0, 50.0, 100.0],
        11.111e-3,
    );
    assert_eq!(rows, vec![3, 0, 0]);
    assert_eq!(eq1_rows(&[10.0], &[5.0, 50.0, 100.0], 1e-3), vec![2]);
    // A duty on the limit is not below it: 50 Hz, 10 ms gives D = 50 %.
    assert_eq!(eq1_rows(&[50.0], &[49.0, 50.0], 10e-3), vec![1]);
}

#[test]
fn every_known_case_has_one_cell_and_eq1_uses_the_camera_exposure() {
    let model = small_model();
    assert_eq!(model.light_levels(), vec![2000.0]);
    let plane = model.plane(2000.0, "fdi_2018").unwrap();
    assert_eq!(plane.frequencies_hz, vec![60.0, 150.0]);
    assert_eq!(plane.duties_percent, vec![20.0, 50.0]);
    assert_eq!(plane.cells.len(), model.cases.len());
    for cell in &plane.cells {
        assert_eq!(plane.frequencies_hz[cell.column], cell.frequency_hz);
        assert!((plane.duties_percent[cell.row] - 100.0 * cell.duty).abs() < 1e-12);
    }
    // Each cell shows its case's value and verdict, in plan order.
    for (cell, case) in plane.cells.iter().zip(&model.cases) {
        assert_eq!(cell.verdict, case.verdict);
        assert_eq!(cell.value, case.rois[0].metrics["fdi_2018"]);
    }
    // 60 Hz: D < 1 - 60 x 11.111 ms = 33.3 %, the 20 % row; 150 Hz: none.
    let eq1 = plane.eq1.unwrap();
    assert!((eq1.exposure_ms - 11.111).abs() < 1e-9);
    assert_eq!(eq1.off_rows, vec![1, 0]);
    assert!(eq1.any_off());
    assert!(model.plane(40.0, "fdi_2018").is_none());
}

#[test]
fn the_plane_of_a_model_read_back_is_the_same() {
    let mut model = small_model();
    let back = read_results(&serde_json::to_string(&model).unwrap()).unwrap();
    let plane = |m: &Results| m.plane(2000.0, "percent_flicker").unwrap();
    let (a, b) = (plane(&model), plane(&back));
    assert_eq!(a.frequencies_hz, b.frequencies_hz);
    assert_eq!(a.duties_percent, b.duties_percent);
    assert_eq!(a.eq1, b.eq1);
    assert_eq!(a.cells, b.cells);
    // Without a camera (a capture) there is no Eq. (1); a case of
    // unknown conditions is on no plane.
    model.dut.camera = None;
    model.cases.to_mut()[0].light_lux = 0.0;
    let plane = plane(&model);
    assert_eq!(plane.eq1, None);
    assert_eq!(plane.cells.len(), model.cases.len() - 1);
}
