//! Sign-off in standard formats, checked with the customer's tools:
//! `pdfsig` (poppler-utils), `openssl cms -verify` and `sha256sum -c`
//! (scripts/test.sh installs what is missing), and `ledflicker verify`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::{ledflicker, root, scratch, text};

const DATE: &str = "2026-01-15";

fn tool(program: &str, args: &[&str], dir: &Path) -> Output {
    Command::new(program)
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap_or_else(|e| panic!("cannot run `{program}` ({e}); scripts/test.sh installs it"))
}

/// Makes a key and certificate; returns (key, certificate).
fn keygen(dir: &Path, name: &str, signer: &str) -> (PathBuf, PathBuf) {
    let key = dir.join(format!("{name}.key"));
    let o = ledflicker(&[
        "keygen",
        "--signer",
        signer,
        "--org",
        "Lab GmbH",
        "--out",
        key.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    (key, dir.join(format!("{name}.crt")))
}

/// pdfsig's report, one block per signature.
fn pdfsig(pdf: &Path) -> Vec<String> {
    let o = tool("pdfsig", &[pdf.to_str().unwrap()], root());
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    out.split("Signature #")
        .skip(1)
        .map(str::to_string)
        .collect()
}

fn verify(dir: &Path, extra: &[&str]) -> Output {
    ledflicker(&[&["verify", dir.to_str().unwrap()], extra].concat())
}

#[test]
fn two_signatories_sign_in_turn_and_standard_tools_verify_both() {
    let base = scratch("signoff-std");
    let keys = base.join("keys");
    std::fs::create_dir_all(&keys).unwrap();
    let (tester, tester_crt) = keygen(&keys, "tester", "Ada Tester, Tested by");
    let (approver, approver_crt) = keygen(&keys, "approver", "Bo Approver, Approved by");
    let (_, stranger_crt) = keygen(&keys, "stranger", "Eve Stranger, Nobody");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(&tester).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o600);
    }
    let pem = std::fs::read_to_string(&tester).unwrap();
    assert!(pem.starts_with("-----BEGIN PRIVATE KEY-----"), "PKCS#8 PEM");
    let o = tool(
        "openssl",
        &[
            "x509",
            "-in",
            tester_crt.to_str().unwrap(),
            "-noout",
            "-subject",
        ],
        root(),
    );
    assert!(
        text(&o).contains("Ada Tester, Tested by") && text(&o).contains("Lab GmbH"),
        "{}",
        text(&o)
    );

    let dir = base.join("report");
    let d = dir.to_str().unwrap();
    let o = ledflicker(&[
        "plan",
        "tests/fixtures/plans/base.toml",
        "--out",
        d,
        "--date",
        DATE,
        "-q",
        "--sign-key",
        tester.to_str().unwrap(),
        "--signer",
        "Ada Tester, Tested by",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    // The marker, written before the signature, is covered by it.
    let manifest = std::fs::read_to_string(dir.join("manifest.txt")).unwrap();
    let sum = text(&tool("sha256sum", &[".ledflicker"], &dir));
    let line = format!("{}  .ledflicker", sum.split_whitespace().next().unwrap());
    assert!(manifest.lines().any(|l| l == line), "{manifest}");
    let o = ledflicker(&[
        "sign",
        d,
        "--key",
        approver.to_str().unwrap(),
        "--signer",
        "Bo Approver, Approved by",
        "--date",
        "2026-01-16",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));

    // pdfsig: both valid, the last covers the whole file.
    let pdf = dir.join("report.pdf");
    let sigs = pdfsig(&pdf);
    assert_eq!(sigs.len(), 2, "{sigs:?}");
    for s in &sigs {
        assert!(s.contains("Signature is Valid"), "{s}");
        assert!(s.contains("adbe.pkcs7.detached"), "{s}");
    }
    assert!(
        sigs[0].contains("Ada Tester, Tested by") && sigs[0].contains("Not total document signed")
    );
    assert!(
        sigs[1].contains("Bo Approver, Approved by") && sigs[1].contains("Total document signed")
    );
    assert!(!sigs[1].contains("Not total"), "{}", sigs[1]);
    // The signature blocks carry the reason.
    let o = tool("pdftotext", &[pdf.to_str().unwrap(), "-"], root());
    assert!(!text(&o).contains("DRAFT"), "a signed PDF is no draft");

    // One flipped byte inside the signed range: pdfsig reports it invalid.
    let mut bytes = std::fs::read(&pdf).unwrap();
    bytes[2000] ^= 0x01;
    let flipped = base.join("flipped.pdf");
    std::fs::write(&flipped, &bytes).unwrap();
    for s in pdfsig(&flipped) {
        assert!(!s.contains("Signature is Valid"), "{s}");
    }

    // openssl cms: the manifest signature checks with the signer's certificate.
    let cms = |content: &str| {
        tool(
            "openssl",
            &[
                "cms",
                "-verify",
                "-binary",
                "-inform",
                "PEM",
                "-in",
                "signoff.p7s",
                "-content",
                content,
                "-CAfile",
                approver_crt.to_str().unwrap(),
                "-out",
                "/dev/null",
            ],
            &dir,
        )
    };
    let o = cms("manifest.txt");
    assert!(o.status.success(), "{}", text(&o));
    let manifest = std::fs::read_to_string(dir.join("manifest.txt")).unwrap();
    let changed = base.join("changed-manifest.txt");
    std::fs::write(
        &changed,
        manifest.replacen("results.json", "results.jsom", 1),
    )
    .unwrap();
    assert!(!cms(changed.to_str().unwrap()).status.success());
    // sha256sum checks every file of the manifest.
    let o = tool("sha256sum", &["--strict", "-c", "manifest.txt"], &dir);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("report.pdf: OK") && text(&o).contains("results.json: OK"));
    assert!(manifest.contains("# input plan "), "{manifest}");

    // verify: no --trust never exits 0; the right certificates do; a wrong
    // one fails and names the signer claimed.
    let o = verify(&dir, &[]);
    assert_eq!(o.status.code(), Some(6), "{}", text(&o));
    assert!(text(&o).contains("IDENTITY NOT CHECKED"), "{}", text(&o));
    let t = tester_crt.to_str().unwrap();
    let a = approver_crt.to_str().unwrap();
    let o = verify(&dir, &["--trust", t, "--trust", a]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let o = verify(&dir, &["--trust", keys.to_str().unwrap()]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "a directory of certificates: {}",
        text(&o)
    );
    let o = verify(
        &dir,
        &["--trust", t, "--trust", stranger_crt.to_str().unwrap()],
    );
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("claims to be by \"Bo Approver, Approved by\""),
        "{}",
        text(&o)
    );
    tamper_checks(&dir, &[t, a]);
}

/// Every kind of tampering is a mismatch (exit 1) naming what changed.
fn tamper_checks(dir: &Path, certs: &[&str]) {
    let trust: Vec<&str> = certs.iter().flat_map(|c| ["--trust", *c]).collect();
    let expect_fail = |needle: &str| {
        let o = verify(dir, &trust);
        assert_eq!(o.status.code(), Some(1), "{}", text(&o));
        assert!(
            text(&o).contains(needle),
            "`{needle}` not in:\n{}",
            text(&o)
        );
    };
    // A dotfile added to traces/.
    let evil = dir.join("traces/.evil.csv");
    std::fs::write(&evil, "frame\n").unwrap();
    expect_fail("`traces/.evil.csv` was added");
    std::fs::remove_file(&evil).unwrap();
    // A changed trace.
    let trace = dir.join("traces/2000lux-150hz-50pct.csv");
    let original = std::fs::read(&trace).unwrap();
    std::fs::write(&trace, b"frame,time_s\n").unwrap();
    expect_fail("`traces/2000lux-150hz-50pct.csv` has changed");
    std::fs::write(&trace, &original).unwrap();
    // A FIFO is refused without being opened (opening it would block).
    #[cfg(unix)]
    {
        let fifo = dir.join("charts/pipe");
        assert!(
            tool("mkfifo", &[fifo.to_str().unwrap()], root())
                .status
                .success()
        );
        expect_fail("special file");
        std::fs::remove_file(&fifo).unwrap();
    }
    // A non-UTF-8 or truncated signature is a mismatch, not a usage error.
    let p7s = dir.join("signoff.p7s");
    let sig = std::fs::read(&p7s).unwrap();
    std::fs::write(&p7s, [&sig[..40], &[0xff, 0xfe, 0x00][..]].concat()).unwrap();
    expect_fail("signoff.p7s");
    std::fs::write(&p7s, &sig[..sig.len() / 2]).unwrap();
    expect_fail("signoff.p7s");
    std::fs::write(&p7s, &sig).unwrap();
    // An edited marker: a later run would take a user's file for its own.
    let marker = dir.join(".ledflicker");
    let m = std::fs::read(&marker).unwrap();
    std::fs::write(&marker, [&m[..], b"notes.txt\n"].concat()).unwrap();
    expect_fail("`.ledflicker` has changed");
    std::fs::write(&marker, &m).unwrap();
    // A deleted results.json.
    let results = dir.join("results.json");
    let r = std::fs::read(&results).unwrap();
    std::fs::remove_file(&results).unwrap();
    expect_fail("`results.json` is missing");
    std::fs::write(&results, &r).unwrap();
    // An edited earlier manifest breaks its signature.
    let first = dir.join("signatures/1.manifest.txt");
    let m = std::fs::read_to_string(&first).unwrap();
    std::fs::write(&first, m.replace("Ada Tester", "Eve Forger")).unwrap();
    expect_fail("signature 1 of 2");
    std::fs::write(&first, &m).unwrap();
    let o = verify(dir, &trust);
    assert_eq!(o.status.code(), Some(0), "restored: {}", text(&o));
}

#[test]
fn keys_never_enter_a_report_and_old_sign_offs_are_recognised() {
    let base = scratch("signoff-guards");
    let keys = base.join("keys");
    std::fs::create_dir_all(&keys).unwrap();
    let (key, crt) = keygen(&keys, "k", "Kim Key, Tested by");
    let dir = base.join("report");
    let d = dir.to_str().unwrap();
    let o = ledflicker(&[
        "plan",
        "tests/fixtures/plans/base.toml",
        "--out",
        d,
        "--date",
        DATE,
        "-q",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    // Unsigned: not verified.
    let o = verify(&dir, &[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).contains("unsigned DRAFT"), "{}", text(&o));

    // keygen refuses to write into a report directory.
    let o = ledflicker(&[
        "keygen",
        "--signer",
        "X",
        "--out",
        dir.join("x.key").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(!dir.join("x.key").exists());

    // A key inside the report, reached through symbolic links, is refused.
    #[cfg(unix)]
    {
        use std::os::unix::fs::symlink;
        let inside = dir.join("traces").join("k.key");
        std::fs::copy(&key, &inside).unwrap();
        let alias = keys.join("alias.key");
        symlink(&inside, &alias).unwrap();
        let link_dir = base.join("link");
        symlink(&dir, &link_dir).unwrap();
        for (report, k) in [
            (d, alias.to_str().unwrap()),
            (link_dir.to_str().unwrap(), inside.to_str().unwrap()),
        ] {
            let o = ledflicker(&[
                "sign",
                report,
                "--key",
                k,
                "--cert",
                crt.to_str().unwrap(),
                "--signer",
                "K",
            ]);
            assert_eq!(o.status.code(), Some(2), "{}", text(&o));
            assert!(
                text(&o).contains("inside the report directory"),
                "{}",
                text(&o)
            );
        }
        std::fs::remove_file(&inside).unwrap();
        assert!(!dir.join("manifest.txt").exists());
    }

    // The old Ed25519 format is recognised and the way to re-sign named.
    std::fs::write(
        dir.join("signoff.json"),
        r#"{"schema":"ledflicker.signoff/1","signatures":[]}"#,
    )
    .unwrap();
    let o = verify(&dir, &[]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("old format") && text(&o).contains("--force"),
        "{}",
        text(&o)
    );
    let o = ledflicker(&["sign", d, "--key", key.to_str().unwrap(), "--signer", "K"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    // A signed report (either format) is not overwritten without --force.
    let o = ledflicker(&["plan", "tests/fixtures/plans/base.toml", "--out", d, "-q"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--force"));
    let o = ledflicker(&[
        "plan",
        "tests/fixtures/plans/base.toml",
        "--out",
        d,
        "--date",
        DATE,
        "-q",
        "--force",
        "--sign-key",
        key.to_str().unwrap(),
        "--signer",
        "Kim Key, Tested by",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(!dir.join("signoff.json").exists());
    let o = verify(&dir, &["--trust", crt.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
}

#[test]
fn pkcs12_from_openssl_signs() {
    let base = scratch("signoff-p12");
    let (key, crt) = keygen(&base, "k", "Pat Twelve, Approved by");
    let p12 = base.join("k.p12");
    let o = tool(
        "openssl",
        &[
            "pkcs12",
            "-export",
            "-inkey",
            key.to_str().unwrap(),
            "-in",
            crt.to_str().unwrap(),
            "-out",
            p12.to_str().unwrap(),
            "-passout",
            "pass:s3cret words",
        ],
        root(),
    );
    assert!(o.status.success(), "{}", text(&o));
    let dir = base.join("report");
    let d = dir.to_str().unwrap();
    let o = ledflicker(&[
        "plan",
        "tests/fixtures/plans/base.toml",
        "--out",
        d,
        "--date",
        DATE,
        "-q",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let sign = |pass: &str| {
        Command::new(env!("CARGO_BIN_EXE_ledflicker"))
            .env("LEDFLICKER_DB", crate::test_db())
            .args([
                "sign",
                d,
                "--p12",
                p12.to_str().unwrap(),
                "--signer",
                "Pat Twelve, Approved by",
            ])
            .current_dir(root())
            .env("LEDFLICKER_P12_PASSPHRASE", pass)
            .output()
            .unwrap()
    };
    let o = sign("wrong");
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("passphrase"), "{}", text(&o));
    let o = sign("s3cret words");
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let o = verify(&dir, &["--trust", crt.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
}

#[test]
fn p2020_inputs_are_bound_and_a_changed_video_is_named() {
    let base = scratch("signoff-inputs");
    // The plan and its videos, copied so that one can be changed.
    let plans = base.join("test-plans");
    let videos = base.join("reference-data/p2020-flicker-videos");
    std::fs::create_dir_all(&plans).unwrap();
    std::fs::create_dir_all(&videos).unwrap();
    std::fs::copy(
        root().join("test-plans/p2020-samples.toml"),
        plans.join("p2020-samples.toml"),
    )
    .unwrap();
    for v in ["test_vid1.mp4", "test_vid2.mp4", "test_vid3.mp4"] {
        std::fs::copy(
            root().join("reference-data/p2020-flicker-videos").join(v),
            videos.join(v),
        )
        .unwrap();
    }
    let (key, crt) = keygen(&base, "k", "Ida Input, Tested by");
    let dir = base.join("report");
    let d = dir.to_str().unwrap();
    let plan = plans.join("p2020-samples.toml");
    let o = ledflicker(&[
        "plan",
        plan.to_str().unwrap(),
        "--out",
        d,
        "--date",
        DATE,
        "-q",
        "--sign-key",
        key.to_str().unwrap(),
        "--signer",
        "Ida Input, Tested by",
    ]);
    assert!(matches!(o.status.code(), Some(0 | 1)), "{}", text(&o));
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("results.json")).unwrap()).unwrap();
    let inputs = results["report"]["inputs"].as_array().unwrap();
    let listed: Vec<&serde_json::Value> = inputs.iter().filter(|i| i["role"] == "video").collect();
    assert_eq!(listed.len(), 3, "{inputs:?}");
    for (i, v) in listed.iter().enumerate() {
        let name = format!("test_vid{}.mp4", i + 1);
        assert!(v["path"].as_str().unwrap().ends_with(&name), "{v}");
        // sha256sum is the independent reference.
        let o = tool("sha256sum", &[&name], &videos);
        let sum = text(&o).split_whitespace().next().unwrap().to_string();
        assert_eq!(v["sha256"].as_str().unwrap(), sum);
        let size = std::fs::metadata(videos.join(&name)).unwrap().len();
        assert_eq!(v["size"].as_u64(), Some(size));
    }
    let manifest = std::fs::read_to_string(dir.join("manifest.txt")).unwrap();
    assert!(manifest.contains("test_vid2.mp4"), "{manifest}");
    let t = crt.to_str().unwrap();
    let o = verify(&dir, &["--trust", t, "--inputs"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("4 input(s) unchanged"), "{}", text(&o));

    // Change one video: verify --inputs names it.
    let v2 = videos.join("test_vid2.mp4");
    let mut bytes = std::fs::read(&v2).unwrap();
    bytes[1000] ^= 0x40;
    std::fs::write(&v2, &bytes).unwrap();
    let o = verify(&dir, &["--trust", t, "--inputs"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("test_vid2.mp4") && text(&o).contains("has changed"),
        "{}",
        text(&o)
    );
    assert!(
        !text(&o).contains("test_vid1.mp4` (video) has changed"),
        "{}",
        text(&o)
    );
    // A deleted input is named as missing.
    std::fs::remove_file(videos.join("test_vid3.mp4")).unwrap();
    let o = verify(&dir, &["--trust", t, "--inputs"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("test_vid3.mp4` (video) is missing"),
        "{}",
        text(&o)
    );
}

/// An unsigned report of the base plan in `base/report`.
fn unsigned_report(base: &Path) -> PathBuf {
    let dir = base.join("report");
    let o = ledflicker(&[
        "plan",
        "tests/fixtures/plans/base.toml",
        "--out",
        dir.to_str().unwrap(),
        "--date",
        DATE,
        "-q",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    dir
}

/// Runs `openssl` in `dir` and asserts that it succeeded.
fn openssl(args: &[&str], dir: &Path) {
    let o = tool("openssl", args, dir);
    assert!(o.status.success(), "openssl {args:?}: {}", text(&o));
}

/// The customer's documented check of a manifest signature
/// (docs/signoff.md), run in `dir`: whether OpenSSL accepts it.
fn openssl_accepts(dir: &Path, p7s: &str, manifest: &str, ca_file: &Path) -> bool {
    let o = tool(
        "openssl",
        &[
            "cms",
            "-verify",
            "-binary",
            "-inform",
            "PEM",
            "-in",
            p7s,
            "-content",
            manifest,
            "-CAfile",
            ca_file.to_str().unwrap(),
            "-out",
            "/dev/null",
        ],
        dir,
    );
    o.status.success()
}

#[test]
fn a_private_key_anywhere_in_the_report_is_refused_and_named() {
    let base = scratch("signoff-keyfiles");
    let keys = base.join("keys");
    std::fs::create_dir_all(&keys).unwrap();
    let (key, crt) = keygen(&keys, "k", "Kim Key, Tested by");
    let dir = unsigned_report(&base);
    // Keys in every format OpenSSL writes, none of them the signing key.
    let k = |name: &str| keys.join(name).to_str().unwrap().to_string();
    let pem = k("other.pem");
    openssl(
        &[
            "genpkey",
            "-algorithm",
            "EC",
            "-pkeyopt",
            "ec_paramgen_curve:P-256",
            "-out",
            &pem,
        ],
        &keys,
    );
    openssl(
        &[
            "pkcs8",
            "-topk8",
            "-nocrypt",
            "-in",
            &pem,
            "-outform",
            "DER",
            "-out",
            &k("other.der"),
        ],
        &keys,
    );
    for (form, out) in [("DER", "other-enc.der"), ("PEM", "other-enc.pem")] {
        openssl(
            &[
                "pkcs8",
                "-topk8",
                "-in",
                &pem,
                "-v2",
                "aes-256-cbc",
                "-passout",
                "pass:x",
                "-outform",
                form,
                "-out",
                &k(out),
            ],
            &keys,
        );
    }
    openssl(&["ec", "-in", &pem, "-out", &k("other-sec1.pem")], &keys);
    openssl(
        &[
            "pkcs12",
            "-export",
            "-inkey",
            key.to_str().unwrap(),
            "-in",
            crt.to_str().unwrap(),
            "-passout",
            "pass:x",
            "-out",
            &k("k.p12"),
        ],
        &keys,
    );
    let sign = |key_file: &Path| {
        ledflicker(&[
            "sign",
            dir.to_str().unwrap(),
            "--key",
            key_file.to_str().unwrap(),
            "--cert",
            crt.to_str().unwrap(),
            "--signer",
            "Kim Key, Tested by",
        ])
    };
    let refused = |o: &Output, rel: &str, what: &str| {
        assert_eq!(o.status.code(), Some(2), "{rel}: {}", text(o));
        assert!(
            text(o).contains(&format!("`{rel}`: {what}")) && text(o).contains("move them out"),
            "{rel}: {}",
            text(o)
        );
        assert!(!dir.join("manifest.txt").exists(), "{rel}");
    };
    for (from, rel, what) in [
        (key.clone(), "traces/notes.csv", "a copy of the signing key"),
        (
            keys.join("other.pem"),
            "charts/.hidden",
            "a PEM private key",
        ),
        (
            keys.join("other-sec1.pem"),
            "notes.txt",
            "a PEM private key",
        ),
        (
            keys.join("other-enc.pem"),
            "traces/a.txt",
            "a PEM private key",
        ),
        (
            keys.join("other.der"),
            "charts/blob.bin",
            "a DER PKCS#8 private key",
        ),
        (
            keys.join("other-enc.der"),
            "blob",
            "an encrypted DER PKCS#8 private key",
        ),
        (keys.join("k.p12"), "traces/k.p12", "a PKCS#12 key store"),
    ] {
        std::fs::copy(&from, dir.join(rel)).unwrap();
        refused(&sign(&key), rel, what);
        std::fs::remove_file(dir.join(rel)).unwrap();
    }
    // `--key` a hard link to a file inside the report: the same file.
    let inside = dir.join("charts/k.key");
    std::fs::copy(&key, &inside).unwrap();
    let link = keys.join("link.key");
    std::fs::hard_link(&inside, &link).unwrap();
    refused(
        &sign(&link),
        "charts/k.key",
        &format!("the signing key `{}` itself", link.display()),
    );
    std::fs::remove_file(&inside).unwrap();
    // The names the manifest leaves out are looked at too.
    let marker = dir.join(".ledflicker");
    let kept = std::fs::read(&marker).ok();
    std::fs::copy(keys.join("other.der"), &marker).unwrap();
    refused(&sign(&key), ".ledflicker", "a DER PKCS#8 private key");
    match &kept {
        Some(bytes) => std::fs::write(&marker, bytes).unwrap(),
        None => std::fs::remove_file(&marker).unwrap(),
    }

    // The report's own files are no keys: it signs, and verify names a key
    // added afterwards as a key, not only as an added file.
    let o = sign(&key);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    std::fs::copy(keys.join("other.der"), dir.join("charts/x.bin")).unwrap();
    let o = verify(&dir, &["--trust", crt.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o)
            .contains("`charts/x.bin`: a DER PKCS#8 private key; a private key must never travel"),
        "{}",
        text(&o)
    );
    std::fs::remove_file(dir.join("charts/x.bin")).unwrap();
    let o = verify(&dir, &["--trust", crt.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
}

#[test]
fn an_empty_folder_is_refused_by_sign_and_named_by_verify() {
    let base = scratch("signoff-empty-dir");
    let (key, crt) = keygen(&base, "k", "Eli Empty, Tested by");
    let dir = unsigned_report(&base);
    let sign = || {
        ledflicker(&[
            "sign",
            dir.to_str().unwrap(),
            "--key",
            key.to_str().unwrap(),
            "--signer",
            "Eli Empty, Tested by",
        ])
    };
    // A folder of empty folders is named once, at its top.
    std::fs::create_dir_all(dir.join("notes/sub")).unwrap();
    let o = sign();
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("`notes/`: a folder without files"),
        "{}",
        text(&o)
    );
    assert!(!text(&o).contains("notes/sub"), "{}", text(&o));
    assert!(!dir.join("manifest.txt").exists());
    std::fs::remove_dir_all(dir.join("notes")).unwrap();
    let o = sign();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let trust = ["--trust", crt.to_str().unwrap()];
    std::fs::create_dir(dir.join("charts/extra")).unwrap();
    let o = verify(&dir, &trust);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("folder `charts/extra/` holds no file"),
        "{}",
        text(&o)
    );
    std::fs::remove_dir(dir.join("charts/extra")).unwrap();
    let o = verify(&dir, &trust);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
}

/// A small PKI made with `openssl ca`: a root CA and certificates it
/// issues for one signing key, with the dates and extensions asked for.
struct Pki {
    dir: PathBuf,
}

impl Pki {
    const CONFIG: &str = "[req]\ndistinguished_name = dn\n[dn]\n\
        [ca]\ndefault_ca = d\n[d]\ndir = .\ndatabase = index.txt\nserial = serial\n\
        new_certs_dir = .\ndefault_md = sha256\npolicy = p\nunique_subject = no\n\
        copy_extensions = none\n[p]\ncommonName = supplied\n\
        [root]\nbasicConstraints = critical,CA:TRUE\nkeyUsage = critical,keyCertSign,cRLSign\n\
        [not_a_ca]\nbasicConstraints = critical,CA:FALSE\nkeyUsage = critical,keyCertSign,cRLSign\n";

    fn new(dir: &Path) -> Pki {
        std::fs::create_dir_all(dir).unwrap();
        std::fs::write(dir.join("ca.cnf"), Self::CONFIG).unwrap();
        std::fs::write(dir.join("index.txt"), "").unwrap();
        std::fs::write(dir.join("serial"), "1000\n").unwrap();
        let pki = Pki {
            dir: dir.to_path_buf(),
        };
        for k in ["ca.key", "signer.key"] {
            pki.run(&[
                "genpkey",
                "-algorithm",
                "EC",
                "-pkeyopt",
                "ec_paramgen_curve:P-256",
                "-out",
                k,
            ]);
        }
        pki
    }

    fn run(&self, args: &[&str]) {
        openssl(args, &self.dir);
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    /// A self-signed CA certificate `NAME.crt` (extensions: a section of
    /// the config).
    fn root(&self, name: &str, section: &str) -> PathBuf {
        let crt = format!("{name}.crt");
        self.run(&[
            "req",
            "-x509",
            "-new",
            "-config",
            "ca.cnf",
            "-extensions",
            section,
            "-key",
            "ca.key",
            "-subj",
            &format!("/CN={name}"),
            "-days",
            "3650",
            "-out",
            &crt,
        ]);
        self.path(&crt)
    }

    /// `NAME.crt` for signer.key, issued by `issuer` (`ISSUER.crt`, key
    /// ca.key); `dates` (start, end) or 30 days from now.
    fn issue(
        &self,
        name: &str,
        issuer: &str,
        ext: &[&str],
        dates: Option<(&str, &str)>,
    ) -> PathBuf {
        let (csr, crt, extfile) = (
            format!("{name}.csr"),
            format!("{name}.crt"),
            format!("{name}.ext"),
        );
        std::fs::write(self.path(&extfile), format!("[x]\n{}\n", ext.join("\n"))).unwrap();
        self.run(&[
            "req",
            "-new",
            "-config",
            "ca.cnf",
            "-key",
            "signer.key",
            "-subj",
            &format!("/CN={name}"),
            "-out",
            &csr,
        ]);
        let issuer_crt = format!("{issuer}.crt");
        let mut args = vec![
            "ca",
            "-batch",
            "-config",
            "ca.cnf",
            "-cert",
            &issuer_crt,
            "-keyfile",
            "ca.key",
            "-in",
            &csr,
            "-out",
            &crt,
            "-extfile",
            &extfile,
            "-extensions",
            "x",
            "-notext",
        ];
        match dates {
            Some((start, end)) => args.extend(["-startdate", start, "-enddate", end]),
            None => args.extend(["-days", "30"]),
        }
        self.run(&args);
        self.path(&crt)
    }
}

/// SHA-256 (hex) of a PEM certificate's DER, as OpenSSL converts it: the
/// manifest's `certificate-sha256`.
fn cert_sha256(crt: &Path) -> String {
    use sha2::Digest;
    let der = crt.with_extension("der");
    openssl(
        &[
            "x509",
            "-in",
            crt.to_str().unwrap(),
            "-outform",
            "DER",
            "-out",
            der.to_str().unwrap(),
        ],
        root(),
    );
    let bytes = std::fs::read(&der).unwrap();
    sha2::Sha256::digest(&bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

#[test]
fn bad_certificates_are_refused_by_sign_and_verify_agrees_with_openssl() {
    let base = scratch("signoff-certs");
    let pki = Pki::new(&base.join("pki"));
    let root_crt = pki.root("root", "root");
    let leaf = ["basicConstraints = critical,CA:FALSE"];
    let signing = [
        "basicConstraints = critical,CA:FALSE",
        "keyUsage = critical,digitalSignature,nonRepudiation",
        "extendedKeyUsage = emailProtection",
    ];
    let ds = "keyUsage = critical,digitalSignature";
    let good = pki.issue("good", "root", &signing, None);
    let plain = pki.issue("plain", "root", &leaf, None);
    // Each bad certificate, and the field sign and verify must name.
    let bad = [
        (
            pki.issue(
                "expired",
                "root",
                &[ds],
                Some(("20200101000000Z", "20210101000000Z")),
            ),
            "notAfter",
        ),
        (
            pki.issue(
                "not-yet-valid",
                "root",
                &[ds],
                Some(("20400101000000Z", "20410101000000Z")),
            ),
            "notBefore",
        ),
        (
            pki.issue(
                "encipherment",
                "root",
                &["keyUsage = critical,keyEncipherment"],
                None,
            ),
            "keyUsage is keyEncipherment",
        ),
        (
            pki.issue(
                "server",
                "root",
                &[ds, "extendedKeyUsage = serverAuth"],
                None,
            ),
            "extendedKeyUsage is serverAuth",
        ),
        (
            pki.issue(
                "code",
                "root",
                &[ds, "extendedKeyUsage = codeSigning"],
                None,
            ),
            "extendedKeyUsage is codeSigning",
        ),
        (
            pki.issue(
                "any-usage",
                "root",
                &[ds, "extendedKeyUsage = anyExtendedKeyUsage"],
                None,
            ),
            "extendedKeyUsage is anyExtendedKeyUsage",
        ),
    ];
    let key = pki.path("signer.key");
    let dir = unsigned_report(&base);
    let sign = |crt: &Path, signer: &str| {
        ledflicker(&[
            "sign",
            dir.to_str().unwrap(),
            "--key",
            key.to_str().unwrap(),
            "--cert",
            crt.to_str().unwrap(),
            "--signer",
            signer,
        ])
    };
    for (crt, field) in &bad {
        let o = sign(crt, "Bad Cert, Tested by");
        assert_eq!(o.status.code(), Some(2), "{}: {}", crt.display(), text(&o));
        assert!(
            text(&o).contains(field) && text(&o).contains(crt.to_str().unwrap()),
            "`{field}` not in: {}",
            text(&o)
        );
        assert!(!dir.join("manifest.txt").exists());
    }
    // plan --sign-key refuses before the run.
    let out = base.join("never");
    let o = ledflicker(&[
        "plan",
        "tests/fixtures/plans/base.toml",
        "--out",
        out.to_str().unwrap(),
        "-q",
        "--sign-key",
        key.to_str().unwrap(),
        "--sign-cert",
        bad[0].0.to_str().unwrap(),
        "--signer",
        "Bad Cert, Tested by",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("notAfter") && !out.exists(),
        "{}",
        text(&o)
    );
    // A signing time set before the certificate's validity is refused.
    let o = Command::new(env!("CARGO_BIN_EXE_ledflicker"))
        .env("LEDFLICKER_DB", crate::test_db())
        .args([
            "sign",
            dir.to_str().unwrap(),
            "--key",
            key.to_str().unwrap(),
        ])
        .args([
            "--cert",
            good.to_str().unwrap(),
            "--signer",
            "Gus Good, Tested by",
        ])
        .current_dir(root())
        .env("SOURCE_DATE_EPOCH", "1577836800")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("notBefore") && text(&o).contains("2020-01-01T00:00:00Z"),
        "{}",
        text(&o)
    );
    // Good certificates sign; verify and OpenSSL accept both signatures.
    for (crt, signer) in [
        (&good, "Gus Good, Tested by"),
        (&plain, "Pam Plain, Approved by"),
    ] {
        let o = sign(crt, signer);
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    }
    let o = verify(&dir, &["--trust", root_crt.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(openssl_accepts(
        &dir,
        "signoff.p7s",
        "manifest.txt",
        &root_crt
    ));
    assert!(openssl_accepts(
        &dir,
        "signatures/1.p7s",
        "signatures/1.manifest.txt",
        &root_crt
    ));

    // The last manifest signed again by OpenSSL with each certificate (the
    // manifest naming it): OpenSSL and verify agree on every one, and
    // verify names what is wrong.
    let (manifest, p7s) = (dir.join("manifest.txt"), dir.join("signoff.p7s"));
    let (kept_manifest, kept_p7s) = (
        std::fs::read_to_string(&manifest).unwrap(),
        std::fs::read(&p7s).unwrap(),
    );
    let plain_sha = cert_sha256(&plain);
    let not_a_ca = pki.root("not-a-ca", "not_a_ca");
    let under_not_a_ca = pki.issue("under-not-a-ca", "not-a-ca", &signing, None);
    // More certificates OpenSSL accepts: one usage of two is enough.
    let non_repudiation = pki.issue(
        "non-repudiation",
        "root",
        &["keyUsage = nonRepudiation"],
        None,
    );
    let email_and_server = pki.issue(
        "email-and-server",
        "root",
        &["extendedKeyUsage = serverAuth, emailProtection"],
        None,
    );
    let mut cases: Vec<(&Path, &Path, Option<&str>)> = vec![
        (plain.as_path(), root_crt.as_path(), None),
        (non_repudiation.as_path(), root_crt.as_path(), None),
        (email_and_server.as_path(), root_crt.as_path(), None),
    ];
    cases.extend(
        bad.iter()
            .map(|(crt, field)| (crt.as_path(), root_crt.as_path(), Some(*field))),
    );
    cases.push((
        under_not_a_ca.as_path(),
        not_a_ca.as_path(),
        Some("basicConstraints does not say CA:TRUE"),
    ));
    // A certificate issued by a CA is no trust anchor on its own, for
    // OpenSSL as for verify.
    cases.push((
        good.as_path(),
        good.as_path(),
        Some("is not among the --trust certificates"),
    ));
    for (crt, anchor, problem) in cases {
        let forged = kept_manifest.replace(&plain_sha, &cert_sha256(crt));
        std::fs::write(&manifest, forged).unwrap();
        pki.run(&[
            "cms",
            "-sign",
            "-binary",
            "-md",
            "sha256",
            "-in",
            manifest.to_str().unwrap(),
            "-signer",
            crt.to_str().unwrap(),
            "-inkey",
            "signer.key",
            "-outform",
            "PEM",
            "-out",
            p7s.to_str().unwrap(),
        ]);
        let openssl_ok = openssl_accepts(&dir, "signoff.p7s", "manifest.txt", anchor);
        let o = verify(&dir, &["--trust", anchor.to_str().unwrap()]);
        let name = crt.display();
        // The PDF signature stays the one of `plain`, so only `plain`
        // verifies whole; the manifest signature's verdict is the lines
        // about signature 2.
        match problem {
            None => {
                assert!(openssl_ok, "{name}");
                if *crt == plain {
                    assert_eq!(o.status.code(), Some(0), "{name}: {}", text(&o));
                }
                assert!(
                    !text(&o).contains("FAIL: signature 2 of 2 claims"),
                    "{name}: {}",
                    text(&o)
                );
            }
            Some(p) => {
                assert!(!openssl_ok, "OpenSSL accepts {name}");
                assert_eq!(o.status.code(), Some(1), "{name}: {}", text(&o));
                let named = text(&o)
                    .lines()
                    .any(|l| l.contains("FAIL: signature 2 of 2 claims") && l.contains(p));
                assert!(
                    named,
                    "`{p}` not said of signature 2 ({name}):\n{}",
                    text(&o)
                );
            }
        }
    }
    std::fs::write(&manifest, &kept_manifest).unwrap();
    std::fs::write(&p7s, &kept_p7s).unwrap();
    let o = verify(&dir, &["--trust", root_crt.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
}
