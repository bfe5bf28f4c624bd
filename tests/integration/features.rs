//! A build without the default features (`cargo test --no-default-features
//! --test integration features::`, as .ci/run does): plans run and write
//! every output but report.pdf, and the sign-off commands say that this
//! build lacks them. In a full build these tests are not compiled; the
//! rest of the suite covers the PDF and the sign-off.

#[cfg(not(feature = "pdf"))]
#[test]
fn a_build_without_the_pdf_writes_every_other_output_and_says_so() {
    let dir = super::scratch("no-pdf");
    let ran = super::ledflicker_in(&["plan", "daylight", "--out", "out"], &dir);
    assert!(
        matches!(ran.status.code(), Some(0 | 1)),
        "{}",
        super::stderr(&ran)
    );
    for name in [
        "results.json",
        "report.html",
        "junit.xml",
        "summary.csv",
        "traces",
        "charts",
    ] {
        assert!(dir.join("out").join(name).exists(), "{name} missing");
    }
    assert!(!dir.join("out/report.pdf").exists());
    assert!(
        super::text(&ran).contains("no report.pdf: this build has no PDF"),
        "{}",
        super::text(&ran)
    );
}

#[cfg(not(feature = "signoff"))]
#[test]
fn a_build_without_the_signoff_refuses_its_commands_with_a_hint() {
    let dir = super::scratch("no-signoff");
    let runs: [&[&str]; 4] = [
        &["keygen", "--signer", "A, B", "--out", "a.key"],
        &["sign", "out", "--key", "a.key", "--signer", "A, B"],
        &["verify", "out"],
        &[
            "plan",
            "daylight",
            "--out",
            "out",
            "--sign-key",
            "a.key",
            "--signer",
            "A, B",
        ],
    ];
    for args in runs {
        let ran = super::ledflicker_in(args, &dir);
        assert_eq!(
            ran.status.code(),
            Some(2),
            "{args:?}: {}",
            super::stderr(&ran)
        );
        let err = super::stderr(&ran);
        assert!(
            err.contains("which this ledflicker was built without")
                && err.contains("default features"),
            "{args:?}: {err}"
        );
        // Refused before any work: nothing was written.
        assert!(
            !dir.join("out").exists() && !dir.join("a.key").exists(),
            "{args:?}"
        );
    }
}

#[cfg(not(feature = "postgres"))]
#[test]
fn a_build_without_postgres_refuses_a_server_with_a_hint_and_hides_the_password() {
    let dir = super::scratch("no-postgres");
    let ran = super::ledflicker_in(
        &[
            "history",
            "--db",
            "postgres://lab:pw-8c1f@127.0.0.1:1/results",
        ],
        &dir,
    );
    assert_eq!(ran.status.code(), Some(2), "{}", super::text(&ran));
    let err = super::stderr(&ran);
    assert!(
        err.contains("which this ledflicker was built without")
            && err.contains("default features")
            && err.contains("postgres://lab:***@127.0.0.1:1/results"),
        "{err}"
    );
    assert!(!err.contains("pw-8c1f"), "{err}");
}
