//! `ledflicker render`: its help lists only the flags it reads, and the
//! frames it writes hold the closed-form levels.

use std::process::Output;

use crate::{ledflicker, scratch, stderr};

/// `ledflicker render ARGS --out OUT`.
fn run_render(args: &str, out: &str) -> Output {
    let mut all = vec!["render"];
    all.extend(args.split_whitespace());
    all.extend(["--out", out]);
    ledflicker(&all)
}

fn help(cmd: &str) -> String {
    let o = ledflicker(&[cmd, "--help"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    String::from_utf8(o.stdout).unwrap()
}

/// `--help` lists `flag` as an option of its own (not as a prefix of another).
fn lists(help: &str, flag: &str) -> bool {
    help.lines().any(|l| {
        l.trim_start()
            .split([' ', ',', '=', '<'])
            .any(|w| w == flag)
    })
}

#[test]
fn render_help_lists_only_the_flags_render_reads() {
    let simulate_only = [
        "--frames",
        "--rows",
        "--summary",
        "--background",
        "--sensor-rows",
        "--rgb-duty",
        "--led-rgb",
        "--background-rgb",
    ];
    let shared = [
        "--frequency-hz",
        "--duty",
        "--pwm-delay-ms",
        "--exposure-ms",
        "--fps",
        "--shutter",
        "--line-time-us",
    ];
    let render = help("render");
    let simulate = help("simulate");
    for flag in simulate_only {
        assert!(lists(&simulate, flag), "simulate --help lacks {flag}");
        assert!(
            !lists(&render, flag),
            "render --help lists {flag}:\n{render}"
        );
    }
    for flag in shared
        .iter()
        .chain(&["--on-s", "--off-s", "--pwm-s", "--out"])
    {
        assert!(
            lists(&render, flag),
            "render --help lacks {flag}:\n{render}"
        );
    }
    // It is refused, not ignored.
    let o = run_render(
        "--frequency-hz 90 --duty 0.5 --exposure-ms 1 --fps 30 --frames 5",
        "unused",
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

/// The grey level of every row of a frame.
fn rows_of(path: &std::path::Path) -> Vec<u8> {
    let img = image::open(path).unwrap().to_luma8();
    assert!(
        (0..img.height())
            .all(|y| (0..img.width()).all(|x| img.get_pixel(x, y) == img.get_pixel(0, y)))
    );
    (0..img.height()).map(|y| img.get_pixel(0, y)[0]).collect()
}

#[test]
fn render_writes_on_off_and_pwm_frames_at_the_closed_form_levels() {
    let dir = scratch("render-frames");
    let out = dir.join("frames");
    // 100 Hz, 25 % duty; 10 ms exposure = one PWM period, so every row of a
    // PWM frame integrates exactly the duty, whatever its phase: 20 + 200 *
    // 0.25 = 70 DN. ON frames are lit at the duty too; OFF frames are the
    // 20 DN background. 30 fps: 0.1 s ON, 0.2 s OFF, 0.1 s PWM = 3 + 6 + 3.
    let o = run_render(
        "--frequency-hz 100 --duty 0.25 --exposure-ms 10 --fps 30 --shutter rolling --line-time-us 30 --on-s 0.1 --off-s 0.2 --pwm-s 0.1 --width 8 --height 40",
        out.to_str().unwrap(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stderr(&o).contains("wrote 12 frames"), "{}", stderr(&o));
    let frame = |k: usize| rows_of(&out.join(format!("frame_{k:06}.png")));
    assert!(!out.join("frame_000012.png").exists());
    for k in 0..3 {
        assert!(
            frame(k).iter().all(|&v| v == 70),
            "ON frame {k}: {:?}",
            frame(k)
        );
    }
    for k in 3..9 {
        assert!(
            frame(k).iter().all(|&v| v == 20),
            "OFF frame {k}: {:?}",
            frame(k)
        );
    }
    for k in 9..12 {
        assert!(
            frame(k).iter().all(|&v| v == 70),
            "PWM frame {k}: {:?}",
            frame(k)
        );
    }

    // A 1 ms exposure at 100 Hz, 50 % duty, rising edge at 0: the LED is ON
    // 0..5 ms. With 200 us per row, rows start over 0..8 ms: those starting
    // before 4 ms see it ON throughout (220 DN), those starting from 5 ms
    // see it OFF (20 DN), the rows between part of each.
    let out2 = dir.join("bands");
    let o = run_render(
        "--frequency-hz 100 --duty 0.5 --exposure-ms 1 --fps 30 --shutter rolling --line-time-us 200 --on-s 0 --off-s 0 --pwm-s 0.1 --width 4 --height 40",
        out2.to_str().unwrap(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let rows = rows_of(&out2.join("frame_000000.png"));
    assert!(rows.contains(&220) && rows.contains(&20), "{rows:?}");
}

#[test]
fn render_refuses_a_used_directory_and_sizes_beyond_the_limits() {
    let dir = scratch("render-refuse");
    let args =
        "--frequency-hz 100 --duty 0.5 --exposure-ms 1 --fps 30 --on-s 0 --off-s 0 --pwm-s 0.1";
    // A directory holding a file of the user's: refused, the file untouched.
    let used = dir.join("used");
    std::fs::create_dir_all(&used).unwrap();
    std::fs::write(used.join("frame_000000.png"), b"mine").unwrap();
    let o = run_render(args, used.to_str().unwrap());
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("is not empty"), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(used.join("frame_000000.png")).unwrap(),
        b"mine"
    );
    // An empty directory is fine, and holds only the frames afterwards.
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let o = run_render(args, empty.to_str().unwrap());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let names: Vec<String> = std::fs::read_dir(&empty)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert_eq!(names.len(), 3, "{names:?}");
    assert!(
        names
            .iter()
            .all(|n| n.starts_with("frame_") && n.ends_with(".png"))
    );
    // Sizes a typing slip could give: refused before anything is written.
    let base = "--frequency-hz 100 --duty 0.5 --on-s 0 --off-s 0";
    for (extra, says) in [
        (
            "--exposure-ms 1 --fps 30 --pwm-s 0.1 --width 100000",
            "at most 16384",
        ),
        (
            "--exposure-ms 1 --fps 30 --pwm-s 0.1 --width 10000 --height 10000",
            "at most 40000000 pixels",
        ),
        (
            "--exposure-ms 1 --fps 1000 --pwm-s 1000",
            "at most 100000 frames",
        ),
        (
            "--exposure-ms 1 --fps 100 --pwm-s 2 --width 4000 --height 4000",
            "GB of pixels",
        ),
        (
            "--exposure-ms 1 --fps 5000 --pwm-s 0.1",
            "--fps must be at most 1000",
        ),
        (
            "--exposure-ms 1e9 --fps 30 --pwm-s 0.1",
            "--exposure-ms must be at most 10000",
        ),
    ] {
        let out = dir.join("big");
        let o = run_render(&format!("{base} {extra}"), out.to_str().unwrap());
        assert_eq!(o.status.code(), Some(2), "{extra}: {}", stderr(&o));
        assert!(stderr(&o).contains(says), "{extra}: {}", stderr(&o));
        assert!(!out.exists(), "{extra}: wrote {}", out.display());
    }
}
