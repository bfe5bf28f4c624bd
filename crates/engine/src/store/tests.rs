use super::*;
/// Three simulated cases of the daylight plan, in case order.
fn results() -> Vec<CaseResult> {
    let plan = ledflicker_core::plan::find_and_load("daylight").unwrap();
    let cases = ledflicker_core::plan::expand_cases(&plan);
    let backend = ledflicker_core::backend::for_plan(&plan, None).unwrap();
    let mut results =
        ledflicker_core::runner::run(&plan, &cases[..3], &backend, Some(1), &|_| {}).unwrap();
    ledflicker_core::runner::render_sample_frames(&plan, &mut results, &backend).unwrap();
    assert!(results.iter().any(|r| r.sample_frame.is_some()));
    results
}

/// A partial store (a run stopped) holding every case of `results`.
fn partial_store_of(results: &[CaseResult]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let mut store = Store::create(dir.path(), &key()).unwrap();
    for (i, r) in results.iter().enumerate() {
        store.put(i, r.clone()).unwrap();
    }
    store.close().unwrap();
    dir
}

fn key() -> RunKey {
    RunKey {
        plan_id: "daylight".into(),
        plan_hash: "ab".repeat(32),
        tool: "ledflicker 0.1.0".into(),
        backend: "simulator".into(),
        case_count: 3,
    }
}

#[test]
fn cases_come_back_exactly_and_in_case_order_whatever_order_they_were_stored_in() {
    let results = results();
    let mut files = Vec::new();
    for order in [[0, 1, 2], [2, 0, 1]] {
        let dir = tempfile::tempdir().unwrap();
        let mut store = Store::create(dir.path(), &key()).unwrap();
        for i in order {
            store.put(i, results[i].clone()).unwrap();
        }
        let path = store.finish().unwrap();
        assert_eq!(path, dir.path().join(FILE));
        for name in [PARTIAL, PARTIAL_WAL, PARTIAL_SHM] {
            assert!(!dir.path().join(name).exists(), "{name} is removed");
        }
        assert_eq!(read_cases(&path).unwrap(), results);
        files.push(std::fs::read(&path).unwrap());
    }
    assert!(
        files[0] == files[1],
        "the finished store's bytes do not depend on the order cases finished in"
    );
}

#[test]
fn the_store_answers_queries_on_verdicts_and_metrics() {
    let results = results();
    let dir = tempfile::tempdir().unwrap();
    let mut store = Store::create(dir.path(), &key()).unwrap();
    for (i, r) in results.iter().enumerate() {
        store.put(i, r.clone()).unwrap();
    }
    let path = store.finish().unwrap();
    let conn = Connection::open(&path).unwrap();
    let fdi: f64 = conn
        .query_row(
            "SELECT value FROM roi_metrics WHERE idx = 1 AND roi = ?1 AND metric = 'fdi_2018'",
            [&results[1].acquisition.rois[0].name],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(Some(fdi), results[1].metrics[0].fdi_2018.value);
    let (id, verdict): (String, String) = conn
        .query_row("SELECT id, verdict FROM cases WHERE idx = 2", [], |r| {
            Ok((r.get(0)?, r.get(1)?))
        })
        .unwrap();
    assert_eq!(id, results[2].case.id);
    assert_eq!(verdict, results[2].verdict.as_str());
}

#[test]
fn a_partial_store_resumes_only_for_the_same_run_and_is_never_read_as_finished() {
    let results = results();
    let dir = tempfile::tempdir().unwrap();
    let mut store = Store::create(dir.path(), &key()).unwrap();
    store.put(2, results[2].clone()).unwrap();
    store.put(0, results[0].clone()).unwrap();
    store.close().unwrap();
    let partial = dir.path().join(PARTIAL);
    let e = read_cases(&partial).unwrap_err().to_string();
    assert!(e.contains("did not finish"), "{e}");

    let other = RunKey {
        plan_hash: "cd".repeat(32),
        ..key()
    };
    let e = Store::resume(dir.path(), &other).err().unwrap().to_string();
    assert!(
        e.contains("plan_hash") && e.contains(&"cd".repeat(32)),
        "{e}"
    );

    let (mut store, done) = Store::resume(dir.path(), &key()).unwrap();
    assert_eq!(done.into_iter().collect::<Vec<_>>(), [0, 2]);
    store.put(1, results[1].clone()).unwrap();
    let path = store.finish().unwrap();
    assert_eq!(read_cases(&path).unwrap(), results);
}

#[test]
fn resuming_without_a_partial_store_or_from_a_foreign_file_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let e = Store::resume(dir.path(), &key()).err().unwrap().to_string();
    assert!(e.contains("no partial case store"), "{e}");
    std::fs::write(
        dir.path().join(PARTIAL),
        b"not a database at all, just text",
    )
    .unwrap();
    let e = Store::resume(dir.path(), &key()).err().unwrap();
    assert!(!e.to_string().is_empty());
}

#[test]
fn a_resumed_store_judges_its_cases_again_so_a_forged_verdict_does_not_survive() {
    let plan = ledflicker_core::plan::find_and_load("daylight").unwrap();
    let cases = ledflicker_core::plan::expand_cases(&plan);
    let backend = ledflicker_core::backend::for_plan(&plan, None).unwrap();
    let idx = cases
        .iter()
        .position(|c| c.id == "2000lux-90hz-50pct")
        .unwrap();
    // As the run stores it: with its sample frame.
    let mut genuine =
        ledflicker_core::runner::run(&plan, &cases[idx..=idx], &backend, Some(1), &|_| {})
            .unwrap()
            .remove(0);
    ledflicker_core::runner::render_sample_frame(&plan, &mut genuine, &backend).unwrap();
    assert_eq!(
        genuine.verdict,
        ledflicker_core::metrics::verdict::Verdict::Pass
    );
    // The partial store edited: the case failed, its check too, its
    // figure lowered.
    let mut forged = genuine.clone();
    forged.verdict = ledflicker_core::metrics::verdict::Verdict::Fail;
    for c in &mut forged.checks {
        c.pass = false;
        c.value = Some(0.0);
    }
    let dir = tempfile::tempdir().unwrap();
    let mut store = Store::create(dir.path(), &key()).unwrap();
    store.put(idx, forged).unwrap();
    store.close().unwrap();
    let (mut store, done) = Store::resume(dir.path(), &key()).unwrap();
    assert_eq!(done.into_iter().collect::<Vec<_>>(), [idx]);
    let judge =
        |i: usize, stored: CaseResult| crate::shard::check::stored_case(&plan, &cases, i, stored);
    assert_eq!(store.rejudge(&judge).unwrap(), 1);
    let back = record::decode(&store.read_rows(&[idx]).unwrap().remove(0).1.bytes).unwrap();
    assert_eq!(back.verdict, genuine.verdict);
    assert_eq!(back.checks, genuine.checks);
    // The store's own columns follow the record.
    let verdict: String = store
        .conn
        .query_row(
            "SELECT verdict FROM cases WHERE idx = ?1",
            [idx as i64],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(verdict, "pass");
}

#[test]
fn a_resumed_store_leaves_a_case_judged_as_stored_in_place_and_rewrites_a_forged_column() {
    let plan = ledflicker_core::plan::find_and_load("daylight").unwrap();
    let cases = ledflicker_core::plan::expand_cases(&plan);
    let results = results();
    let dir = partial_store_of(&results);
    // The record kept, the verdict column of case 1 edited.
    let conn = Connection::open(dir.path().join(PARTIAL)).unwrap();
    conn.execute("UPDATE cases SET verdict = 'forged' WHERE idx = 1", [])
        .unwrap();
    drop(conn);
    let (mut store, _) = Store::resume(dir.path(), &key()).unwrap();
    let before = store.conn.total_changes();
    let judge =
        |i: usize, stored: CaseResult| crate::shard::check::stored_case(&plan, &cases, i, stored);
    assert_eq!(store.rejudge(&judge).unwrap(), 3);
    // Case 1 deleted and inserted again (its row and its metrics' rows);
    // cases 0 and 2, judged as stored, not written at all.
    let metrics = results[1].metrics.len() * 7;
    let changed = store.conn.total_changes() - before;
    assert!(
        changed > 0 && changed <= 2 * (1 + metrics as u64),
        "{changed} rows changed"
    );
    let verdict: String = store
        .conn
        .query_row("SELECT verdict FROM cases WHERE idx = 1", [], |r| r.get(0))
        .unwrap();
    assert_eq!(verdict, results[1].verdict.as_str());
    assert_eq!(read_cases(&store.finish().unwrap()).unwrap(), results);
}

#[test]
fn a_case_that_fails_halfway_is_not_stored_in_part() {
    let results = results();
    let dir = tempfile::tempdir().unwrap();
    let mut store = Store::create(dir.path(), &key()).unwrap();
    store.put(0, results[0].clone()).unwrap();
    // Its ROIs twice: its metric rows collide after its case row is written.
    let mut twice = results[1].clone();
    twice
        .acquisition
        .rois
        .extend(twice.acquisition.rois.clone());
    twice.metrics.extend(twice.metrics.clone());
    assert!(store.put(1, twice).is_err());
    // What a stopped run does: commit what is pending, for a resume.
    store.close().unwrap();
    let conn = Connection::open(dir.path().join(PARTIAL)).unwrap();
    let rows = |table: &str| -> i64 {
        conn.query_row(
            &format!("SELECT COUNT(*) AS n FROM {table} WHERE idx = 1"),
            [],
            |r| r.get("n"),
        )
        .unwrap()
    };
    assert_eq!((rows("cases"), rows("roi_metrics")), (0, 0));
    drop(conn);
    let (_, done) = Store::resume(dir.path(), &key()).unwrap();
    assert_eq!(done.into_iter().collect::<Vec<_>>(), [0]);
}

#[test]
fn a_case_row_deleted_by_hand_is_run_again_and_a_record_of_another_type_is_named() {
    let plan = ledflicker_core::plan::find_and_load("daylight").unwrap();
    let cases = ledflicker_core::plan::expand_cases(&plan);
    let results = results();
    let dir = partial_store_of(&results);
    // Case 1's row deleted, its metric rows left behind, as a client that
    // does not enforce foreign keys (sqlite3's default) leaves them.
    let conn = Connection::open(dir.path().join(PARTIAL)).unwrap();
    conn.execute_batch("PRAGMA foreign_keys = OFF; DELETE FROM cases WHERE idx = 1")
        .unwrap();
    drop(conn);
    let (mut store, done) = Store::resume(dir.path(), &key()).unwrap();
    assert_eq!(done.into_iter().collect::<Vec<_>>(), [0, 2]);
    let judge =
        |i: usize, stored: CaseResult| crate::shard::check::stored_case(&plan, &cases, i, stored);
    assert_eq!(store.rejudge(&judge).unwrap(), 2);
    // The case is run again: its metric rows no longer collide.
    store.put(1, results[1].clone()).unwrap();
    assert_eq!(read_cases(&store.finish().unwrap()).unwrap(), results);

    // A record stored as text is named by its case.
    let dir = partial_store_of(&results);
    let conn = Connection::open(dir.path().join(PARTIAL)).unwrap();
    conn.execute("UPDATE cases SET result = 'hello' WHERE idx = 2", [])
        .unwrap();
    drop(conn);
    let (mut store, _) = Store::resume(dir.path(), &key()).unwrap();
    let e = store.rejudge(&judge).err().unwrap();
    assert!(matches!(e, StoreError::Record { idx: 2, .. }), "{e:?}");
    let message = e.to_string();
    assert!(
        message.contains(&format!("`{}` (position 2)", results[2].case.id))
            && message.contains("not a BLOB"),
        "{message}"
    );
}

/// `frame` with row 0's last run one pixel shorter.
fn short_row(
    frame: &ledflicker_core::trace::RenderedFrame,
) -> ledflicker_core::trace::RenderedFrame {
    let mut rows: Vec<Vec<_>> = (0..frame.height).map(|y| frame.runs(y).to_vec()).collect();
    rows[0].last_mut().unwrap().len -= 1;
    ledflicker_core::trace::RenderedFrame::from_runs(
        frame.index,
        frame.width,
        frame.full_scale_dn,
        rows,
    )
}

#[test]
fn a_resume_refuses_a_stored_picture_the_run_cannot_have_made_and_a_case_at_another_position() {
    let plan = ledflicker_core::plan::find_and_load("daylight").unwrap();
    let cases = ledflicker_core::plan::expand_cases(&plan);
    let results = results();
    let judge =
        |i: usize, stored: CaseResult| crate::shard::check::stored_case(&plan, &cases, i, stored);
    let genuine = results[0].clone();
    let frame = genuine.sample_frame.clone().unwrap();
    assert!(judge(0, genuine.clone()).is_ok());

    let mut forged = genuine.clone();
    forged.sample_frame = Some(short_row(&frame));
    let e = judge(0, forged).unwrap_err();
    assert!(
        e.contains("row 0 of the sample frame holds 1279 pixels, not its width 1280"),
        "{e}"
    );

    let mut forged = genuine.clone();
    let mut other = frame.clone();
    other.index += 1;
    forged.sample_frame = Some(other);
    let e = judge(0, forged).unwrap_err();
    assert!(
        e.contains(&format!("the sample frame is frame {}", frame.index + 1)),
        "{e}"
    );

    let mut forged = genuine.clone();
    forged.lit_frame = Some(frame.clone());
    let e = judge(0, forged).unwrap_err();
    assert!(e.contains("the lit frame is frame"), "{e}");

    let e = judge(1, genuine.clone()).unwrap_err();
    assert!(
        e.contains("stored at position 1, it holds the plan's case 0"),
        "{e}"
    );

    // Through the store: the resume stops, naming the case.
    let mut forged = genuine;
    forged.sample_frame = Some(short_row(&frame));
    let dir = partial_store_of(&[forged]);
    let (mut store, _) = Store::resume(dir.path(), &key()).unwrap();
    let e = store.rejudge(&judge).unwrap_err().to_string();
    assert!(
        e.contains(&results[0].case.id) && e.contains("1279 pixels"),
        "{e}"
    );
}
