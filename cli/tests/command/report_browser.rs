//! The `bench dst` HTML report opened in a real headless Chromium: the page
//! parses with both charts, the frame and the heat maps in its DOM, and its
//! screenshot is a picture, not a blank page. Skipped where Chromium is not
//! installed, unless RAYTREE_REQUIRE_CHROMIUM is set (CI sets it).

use std::path::{Path, PathBuf};
use std::process::Command;

fn chromium() -> Option<PathBuf> {
    [
        "/usr/bin/chromium",
        "/usr/bin/chromium-browser",
        "/usr/bin/google-chrome",
    ]
    .iter()
    .map(PathBuf::from)
    .find(|p| p.exists())
}

fn headless(chrome: &Path, profile: &Path, extra: &[&str], page: &Path) -> std::process::Output {
    Command::new(chrome)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--window-size=1200,1600",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(extra)
        .arg(format!("file://{}", page.display()))
        .output()
        .expect("chromium runs")
}

#[test]
fn report_renders_in_chromium() {
    let Some(chrome) = chromium() else {
        assert!(
            std::env::var_os("RAYTREE_REQUIRE_CHROMIUM").is_none(),
            "RAYTREE_REQUIRE_CHROMIUM is set but no Chromium is installed"
        );
        eprintln!("skipping: no Chromium installed");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_raytree"))
        .args([
            "bench",
            "dst",
            "--preset",
            "quick",
            "-s",
            "chess:3000",
            "--width",
            "96",
            "--height",
            "72",
            "--frames",
            "1",
            "-q",
            "--report",
            "rep",
        ])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let page = dir.path().join("rep/report.html");
    let profile = dir.path().join("profile");

    // The DOM as Chromium parsed it.
    let dom = headless(&chrome, &profile, &["--dump-dom"], &page);
    let dom = String::from_utf8_lossy(&dom.stdout);
    assert_eq!(
        dom.matches("<svg").count(),
        2,
        "storage and frame-time charts"
    );
    assert_eq!(
        dom.matches("<img").count(),
        5,
        "the frame and four heat maps"
    );
    assert!(dom.contains("cbvh") && dom.contains("dst-similar"));

    // The screenshot: many colours (charts, heat maps), not a blank page.
    let shot = dir.path().join("shot.png");
    let arg = format!("--screenshot={}", shot.display());
    let r = headless(&chrome, &profile, &[&arg], &page);
    assert!(shot.exists(), "{}", String::from_utf8_lossy(&r.stderr));
    let img = image::open(&shot).unwrap().to_rgb8();
    let colours: std::collections::HashSet<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    assert!(
        colours.len() > 200,
        "only {} colours: a blank page?",
        colours.len()
    );
    // The chart bars' colour is on the page.
    assert!(img.pixels().filter(|p| p.0 == [0x4e, 0x79, 0xa7]).count() > 500);
}
