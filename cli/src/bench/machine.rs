//! What a benchmark ran on, printed beside its figures: a frame time or a
//! ratio means little without the processor, the thread count and how the
//! build was made.

use serde::Serialize;

/// The machine and build a benchmark ran on.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Machine {
    /// The processor's model name (Linux's `/proc/cpuinfo`), or "unknown
    /// processor" where it cannot be read.
    pub cpu: String,
    /// Logical cores the system offers.
    pub logical_cores: usize,
    /// Thread counts the benchmark ran on.
    pub threads: Vec<usize>,
    /// Whether the build is optimized without debug assertions (`--release`).
    pub release: bool,
    /// SIMD extensions compiled in beyond the target's baseline: on x86-64,
    /// present with `-C target-cpu=native` (or explicit target features).
    pub simd: Vec<&'static str>,
    /// The SIMD path the wide kernels (`bvh4`, `bvh8`, `cwbvh`) ran on,
    /// chosen at run time ([`raytree::structures::simd`]).
    pub simd_path: &'static str,
    /// Whether that path was chosen at run time or forced.
    pub simd_chosen: &'static str,
    /// Whether the structures' arrays asked for huge pages
    /// ([`raytree::pages::describe`]).
    pub pages: String,
}

/// x86-64 extensions past its SSE2 baseline that change the code the
/// traversals compile to, with whether this build may use them.
#[cfg(target_arch = "x86_64")]
const EXTENSIONS: [(&str, bool); 6] = [
    ("sse4.1", cfg!(target_feature = "sse4.1")),
    ("avx", cfg!(target_feature = "avx")),
    ("avx2", cfg!(target_feature = "avx2")),
    ("fma", cfg!(target_feature = "fma")),
    ("bmi2", cfg!(target_feature = "bmi2")),
    ("avx512f", cfg!(target_feature = "avx512f")),
];

#[cfg(not(target_arch = "x86_64"))]
const EXTENSIONS: [(&str, bool); 0] = [];

impl Machine {
    /// This machine and build, for a run on each of `threads` threads.
    pub fn detect(threads: &[usize]) -> Self {
        Machine {
            cpu: cpu_model().unwrap_or_else(|| "unknown processor".to_owned()),
            logical_cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
            threads: threads.to_vec(),
            release: !cfg!(debug_assertions),
            simd: EXTENSIONS.iter().filter(|e| e.1).map(|e| e.0).collect(),
            simd_path: raytree::structures::simd::active().describe(),
            simd_chosen: raytree::structures::simd::how_chosen(),
            pages: raytree::pages::describe(),
        }
    }

    /// One line for a report's head.
    pub fn describe(&self) -> String {
        let build = if self.release {
            "release build"
        } else {
            "debug build (timings do not represent raytree: build with --release)"
        };
        let simd = if self.simd.is_empty() {
            "no SIMD past the target's baseline (target-cpu=native off)".to_owned()
        } else {
            format!("SIMD past the baseline: {}", self.simd.join(", "))
        };
        let threads: Vec<String> = self.threads.iter().map(|t| t.to_string()).collect();
        format!(
            "machine: {}, {} logical cores; {} threads; {build}; {simd}; wide kernels on the {} SIMD path ({}); {}",
            self.cpu,
            self.logical_cores,
            threads.join(" and "),
            self.simd_path,
            self.simd_chosen,
            self.pages
        )
    }
}

/// A benchmark's JSON: the machine it ran on beside its results, so that
/// a figure read back later still says where it came from.
#[derive(Debug, Serialize)]
pub struct Measured<'a, T> {
    pub machine: &'a Machine,
    pub scenes: &'a [T],
}

/// The first "model name" of `/proc/cpuinfo`.
fn cpu_model() -> Option<String> {
    let info = std::fs::read_to_string("/proc/cpuinfo").ok()?;
    model_name(&info)
}

fn model_name(cpuinfo: &str) -> Option<String> {
    cpuinfo.lines().find_map(|l| {
        let (key, value) = l.split_once(':')?;
        (key.trim() == "model name" && !value.trim().is_empty()).then(|| value.trim().to_owned())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_model_name_is_the_first_non_empty_one() {
        let info = "processor\t: 0\nvendor_id\t: AuthenticAMD\nmodel name\t: AMD EPYC 7B13\n\nprocessor\t: 1\nmodel name\t: other\n";
        assert_eq!(model_name(info).as_deref(), Some("AMD EPYC 7B13"));
        assert_eq!(
            model_name("model name\t:\nmodel name : X"),
            Some("X".into())
        );
        assert_eq!(model_name("processor : 0\n"), None);
    }

    #[test]
    fn describes_threads_build_and_simd() {
        let m = Machine::detect(&[1, 3]);
        assert_eq!(m.threads, [1, 3]);
        assert!(m.logical_cores >= 1 && !m.cpu.is_empty());
        // Tests build with debug assertions on.
        assert_eq!(m.release, !cfg!(debug_assertions));
        let line = m.describe();
        assert!(line.contains("1 and 3 threads"), "{line}");
        assert!(
            line.contains(&format!(
                "wide kernels on the {} SIMD path",
                raytree::structures::simd::active().describe()
            )),
            "{line}"
        );
        assert!(line.ends_with(&raytree::pages::describe()), "{line}");
        assert!(line.contains(if m.release {
            "release build"
        } else {
            "debug build"
        }));
        let plain = Machine {
            simd: Vec::new(),
            ..m.clone()
        };
        assert!(plain.describe().contains("target-cpu=native off"));
        let native = Machine {
            simd: vec!["avx2", "fma"],
            ..m
        };
        assert!(native
            .describe()
            .contains("SIMD past the baseline: avx2, fma"));
    }
}
