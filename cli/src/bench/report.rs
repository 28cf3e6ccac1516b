//! The `bench dst` report files: one self-contained HTML page (tables, SVG
//! bar charts like the dual-split paper's Figure 10, the rendered frames
//! and per-pixel heat maps like its Figure 1, images inlined as data URIs)
//! and a CSV file with one row per scene and structure.

use super::dst::{percent_cell, same_image_cell, SceneResult, VsBvh};
use super::machine::Machine;
use super::svg::{stacked_bars, Bar};
use base64::Engine;
use raytree::stats::MIB;

/// The CSV columns, in order.
pub const CSV_HEADER: &str = "scene,triangles,structure,bytes,node_bytes,index_bytes,storage_ratio,node_storage_ratio,nodes,conversion_seconds,frame_seconds,frame_ratio,mrays_per_second,nodes_per_ray,planes_per_ray,triangles_per_ray,nodes_ratio,planes_ratio,triangles_ratio,same_image";

/// One CSV row per scene and structure; the ratio cells are empty when the
/// BVH was not measured.
pub fn csv(results: &[SceneResult]) -> String {
    let mut s = String::from(CSV_HEADER);
    s.push('\n');
    for r in results {
        for row in &r.rows {
            let v = row.vs_bvh;
            let ratio = |f: fn(&VsBvh) -> f64| v.map_or(String::new(), |v| f(&v).to_string());
            s += &format!(
                "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
                csv_field(&r.scene),
                r.triangles,
                row.structure.name(),
                row.bytes,
                row.node_bytes,
                row.index_bytes,
                ratio(|v| v.storage_ratio),
                ratio(|v| v.node_storage_ratio),
                row.nodes,
                row.conversion_seconds,
                row.frame_seconds,
                ratio(|v| v.frame_ratio),
                row.mrays_per_second,
                row.per_ray.nodes,
                row.per_ray.planes,
                row.per_ray.triangles,
                ratio(|v| v.nodes_ratio),
                ratio(|v| v.planes_ratio),
                ratio(|v| v.triangles_ratio),
                v.map_or(String::new(), |v| v.same_image.to_string())
            );
        }
    }
    s
}

/// A field quoted when it holds a comma, quote or line break.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn img(png: &[u8], alt: &str) -> String {
    format!(
        r#"<img alt="{}" src="data:image/png;base64,{}">"#,
        escape(alt),
        base64::engine::general_purpose::STANDARD.encode(png)
    )
}

/// A bar chart per structure of one scene: `value` gives the bar's
/// segments and its ratio to the BVH.
fn chart(
    r: &SceneResult,
    title: &str,
    segments: &[&str],
    unit: &str,
    value: impl Fn(&super::dst::Row) -> (Vec<f64>, Option<f64>),
) -> String {
    let bars: Vec<Bar> = r
        .rows
        .iter()
        .map(|row| {
            let (v, ratio) = value(row);
            Bar {
                label: row.structure.name().to_owned(),
                segments: v,
                note: ratio.map_or(String::new(), |x| format!("{:.1}% of bvh", 100.0 * x)),
            }
        })
        .collect();
    stacked_bars(&format!("{}: {title}", r.scene), segments, unit, &bars)
}

/// The HTML report; `markdown` holds each scene's table as the command
/// printed it.
pub fn html(results: &[SceneResult], markdown: &[String], machine: &Machine) -> String {
    let mut s = String::from(
        r#"<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>raytree bench dst</title>
<style>
body { font-family: sans-serif; margin: 2em; max-width: 1200px; }
table { border-collapse: collapse; margin: 1em 0; font-size: 13px; }
td, th { border: 1px solid #ccc; padding: 3px 6px; text-align: right; }
td:first-child, th:first-child { text-align: left; }
figure { display: inline-block; margin: 0.5em; vertical-align: top; }
figcaption { font-size: 13px; }
img { image-rendering: pixelated; max-width: 512px; }
</style></head><body>
<h1>Dual-split trees and their baselines: storage, frame time, per-ray work</h1>
<p>Every structure is converted from one BVH per scene; path tracing at 1 sample per pixel with 5 diffuse bounces. Each structure renders one untimed frame that counts the work (the images and heat maps come from it); the timed frames run with counting compiled out, round-robin over the structures. Ratios are to the uncompressed BVH (52-byte inner nodes, 4-byte leaves) in the same run. Storage counts the nodes and the triangle index list; <em>nodes</em> counts the nodes alone, in MiB, as the paper's Table 1 does.</p>
"#,
    );
    s += &format!("<p>{}</p>\n", escape(&machine.describe()));
    if let Some(md) = super::dst::summary(results) {
        s += &format!(
            "<section><h2>All scenes</h2><pre>{}</pre></section>\n",
            escape(&md)
        );
    }
    for (k, r) in results.iter().enumerate() {
        s += &format!(
            "<section class=\"scene\"><h2>{} ({} triangles)</h2>\n",
            escape(&r.scene),
            r.triangles
        );
        s += "<table>\n<tr><th>structure</th><th>storage MB</th><th>vs bvh</th><th>nodes MiB</th><th>vs bvh</th><th>frame s</th><th>vs bvh</th><th>nodes/ray</th><th>plane tests/ray</th><th>triangle tests/ray</th><th>same image</th></tr>\n";
        for row in &r.rows {
            let v = row.vs_bvh;
            let pct = |f: fn(&VsBvh) -> f64| percent_cell(v, f);
            s += &format!(
                "<tr><td>{}</td><td>{:.3}</td><td>{}</td><td>{:.3}</td><td>{}</td><td>{:.4}</td><td>{}</td><td>{:.2}</td><td>{:.1}</td><td>{:.2}</td><td>{}</td></tr>\n",
                row.structure.name(),
                row.bytes as f64 / 1e6,
                pct(|v| v.storage_ratio),
                row.node_bytes as f64 / MIB,
                pct(|v| v.node_storage_ratio),
                row.frame_seconds,
                pct(|v| v.frame_ratio),
                row.per_ray.nodes,
                row.per_ray.planes,
                row.per_ray.triangles,
                same_image_cell(v)
            );
        }
        s += "</table>\n<div class=\"charts\">\n";
        s += &chart(
            r,
            "storage",
            &["nodes", "triangle index list"],
            "MB",
            |row| {
                (
                    vec![row.node_bytes as f64 / 1e6, row.index_bytes as f64 / 1e6],
                    row.vs_bvh.map(|v| v.storage_ratio),
                )
            },
        );
        s += &chart(r, "frame time", &["frame time"], "s", |row| {
            (vec![row.frame_seconds], row.vs_bvh.map(|v| v.frame_ratio))
        });
        s += "</div>\n<div class=\"pictures\">\n";
        if !r.pictures.frame.is_empty() {
            s += &format!(
                "<figure>{}<figcaption>the frame ({}×{}, 1 spp)</figcaption></figure>\n",
                img(&r.pictures.frame, "rendered frame"),
                r.width,
                r.height
            );
        }
        for h in &r.pictures.heatmaps {
            s += &format!(
                "<figure>{}<figcaption>{} per pixel, {}: mean {:.1}; scale 0 (dark) to {} (white)</figcaption></figure>\n",
                img(&h.png, &format!("{} heat map, {}", h.measure.name(), h.structure.name())),
                h.measure.name(),
                h.structure.name(),
                h.mean,
                h.scale_top
            );
        }
        s += "</div>\n";
        if let Some(md) = markdown.get(k) {
            s += &format!(
                "<details><summary>Tables 1–3 as printed</summary><pre>{}</pre></details>\n",
                escape(md)
            );
        }
        s += "</section>\n";
    }
    s += "</body></html>\n";
    s
}
