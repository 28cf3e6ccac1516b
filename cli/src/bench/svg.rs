//! Self-contained SVG bar charts for benchmark reports.

/// One bar: a label and stacked segments (value, segment name).
pub struct Bar {
    pub label: String,
    pub segments: Vec<f64>,
    /// Text after the bar (a ratio, a state size).
    pub note: String,
}

const COLORS: [&str; 4] = ["#4e79a7", "#f28e2b", "#59a14f", "#e15759"];

/// A horizontal stacked bar chart: `title`, the meaning of each segment,
/// the unit of the axis, and the bars from top to bottom.
pub fn stacked_bars(title: &str, segment_names: &[&str], unit: &str, bars: &[Bar]) -> String {
    let (left, right, top, row) = (150.0, 190.0, 50.0, 22.0);
    let width = 820.0;
    let plot = width - left - right;
    let height = top + row * bars.len() as f64 + 40.0;
    let max = bars
        .iter()
        .map(|b| b.segments.iter().sum::<f64>())
        .fold(0.0f64, f64::max)
        .max(1e-12);
    let mut s = format!(
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" font-family="sans-serif" font-size="12">
<rect width="100%" height="100%" fill="white"/>
<text x="{left}" y="20" font-size="14" font-weight="bold">{}</text>
"#,
        escape(title)
    );
    for (k, name) in segment_names.iter().enumerate() {
        let x = left + 120.0 * k as f64;
        s += &format!(
            r#"<rect x="{x}" y="30" width="10" height="10" fill="{}"/><text x="{}" y="39">{}</text>
"#,
            COLORS[k % COLORS.len()],
            x + 14.0,
            escape(name)
        );
    }
    for (i, b) in bars.iter().enumerate() {
        let y = top + row * i as f64;
        s += &format!(
            r#"<text x="{}" y="{}" text-anchor="end">{}</text>
"#,
            left - 6.0,
            y + 15.0,
            escape(&b.label)
        );
        let mut x = left;
        for (k, v) in b.segments.iter().enumerate() {
            let w = plot * v / max;
            s += &format!(
                r#"<rect x="{x:.1}" y="{}" width="{w:.1}" height="{}" fill="{}"><title>{}: {v:.4} {unit}</title></rect>
"#,
                y + 3.0,
                row - 6.0,
                COLORS[k % COLORS.len()],
                escape(segment_names.get(k).copied().unwrap_or(""))
            );
            x += w;
        }
        s += &format!(
            r#"<text x="{:.1}" y="{}">{}</text>
"#,
            x + 6.0,
            y + 15.0,
            escape(&format!(
                "{:.3} {unit}  {}",
                b.segments.iter().sum::<f64>(),
                b.note
            ))
        );
    }
    s += "</svg>\n";
    s
}

fn escape(t: &str) -> String {
    t.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chart_has_every_bar() {
        let bars = vec![
            Bar {
                label: "stack".into(),
                segments: vec![1.0, 2.0],
                note: "1.00".into(),
            },
            Bar {
                label: "a<b".into(),
                segments: vec![0.5, 0.5],
                note: String::new(),
            },
        ];
        let svg = stacked_bars("t", &["eye", "AO"], "s", &bars);
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert_eq!(svg.matches("<rect x=").count(), 2 + 4);
        assert!(svg.contains("a&lt;b"));
    }
}
