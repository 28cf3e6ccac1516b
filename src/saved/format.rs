//! The container of a saved file: a fixed header, a table of sections,
//! the sections themselves (64-byte aligned, zero padded), XXH3-64
//! checksums; and the two small codecs the structures use to write their
//! arrays ([`Sections`]) and read them back ([`Source`], [`RecordReader`]).
//! What the arrays mean belongs to each structure's folder.

use bytemuck::Pod;
use std::borrow::Cow;
use std::sync::atomic::{AtomicBool, Ordering};
use xxhash_rust::xxh3::xxh3_64;

/// Every section starts at a multiple of this many bytes (a cache line;
/// every array's element alignment divides it).
pub const ALIGN: usize = 64;
/// Bytes of the fixed part of the header, before the section table.
pub const FIXED: usize = 192;
/// Bytes of one section table entry.
pub const ENTRY: usize = 64;
/// Bytes of a section's name field (ASCII, NUL padded).
pub const NAME_BYTES: usize = 24;
/// The most sections a file may have.
pub const MAX_SECTIONS: usize = 32;
/// Where the header's own checksum lies (it is zero while computed).
pub const HEADER_CHECKSUM_AT: usize = 184;

/// A section's bytes, borrowed from the structure or made for the file.
pub struct Section<'a> {
    pub name: &'static str,
    pub elem: u32,
    pub bytes: Cow<'a, [u8]>,
}

/// The sections a structure (and the scene and BVH beside it) write, in
/// order.
#[derive(Default)]
pub struct Sections<'a> {
    pub list: Vec<Section<'a>>,
}

impl<'a> Sections<'a> {
    /// An array, borrowed.
    pub fn slice<T: Pod>(&mut self, name: &'static str, data: &'a [T]) {
        self.push(
            name,
            std::mem::size_of::<T>(),
            Cow::Borrowed(bytemuck::cast_slice(data)),
        );
    }

    /// An array made for the file.
    pub fn owned<T: Pod>(&mut self, name: &'static str, data: Vec<T>) {
        let bytes = bytemuck::cast_slice::<T, u8>(&data).to_vec();
        self.push(name, std::mem::size_of::<T>(), Cow::Owned(bytes));
    }

    /// A record of scalars and strings.
    pub fn record(&mut self, name: &'static str, r: RecordWriter) {
        self.push(name, 1, Cow::Owned(r.0));
    }

    fn push(&mut self, name: &'static str, elem: usize, bytes: Cow<'a, [u8]>) {
        debug_assert!(name.len() < NAME_BYTES && name.is_ascii());
        debug_assert!(self.list.iter().all(|s| s.name != name), "{name} twice");
        self.list.push(Section {
            name,
            elem: elem as u32,
            bytes,
        });
    }
}

/// Rounds `n` up to a multiple of [`ALIGN`].
pub fn align(n: usize) -> usize {
    n.div_ceil(ALIGN) * ALIGN
}

/// XXH3-64 (seed 0) of `bytes`.
pub fn checksum(bytes: &[u8]) -> u64 {
    xxh3_64(bytes)
}

/// A little-endian record of scalars and length-prefixed UTF-8 strings.
#[derive(Default)]
pub struct RecordWriter(pub Vec<u8>);

impl RecordWriter {
    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    pub fn u64(&mut self, v: u64) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    pub fn f32(&mut self, v: f32) -> &mut Self {
        self.u32(v.to_bits())
    }
    pub fn f64(&mut self, v: f64) -> &mut Self {
        self.u64(v.to_bits())
    }
    pub fn f32s(&mut self, v: &[f32]) -> &mut Self {
        for &x in v {
            self.f32(x);
        }
        self
    }
    pub fn str(&mut self, s: &str) -> &mut Self {
        self.u32(s.len() as u32);
        self.0.extend_from_slice(s.as_bytes());
        self
    }
}

/// Reads a [`RecordWriter`]'s record back; every read checks that the
/// bytes are there, and [`RecordReader::finish`] that none are left over.
pub struct RecordReader<'a> {
    name: &'static str,
    bytes: &'a [u8],
    at: usize,
}

impl<'a> RecordReader<'a> {
    pub fn new(name: &'static str, bytes: &'a [u8]) -> Self {
        RecordReader { name, bytes, at: 0 }
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        match end {
            Some(end) => {
                let s = &self.bytes[self.at..end];
                self.at = end;
                Ok(s)
            }
            None => Err(format!(
                "section '{}' ends at byte {} inside a field of {n} bytes",
                self.name,
                self.bytes.len()
            )),
        }
    }
    pub fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().unwrap()))
    }
    pub fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().unwrap()))
    }
    /// A count or an index that must fit `usize`.
    pub fn usize(&mut self) -> Result<usize, String> {
        let v = self.u64()?;
        usize::try_from(v).map_err(|_| format!("section '{}': {v} is too large", self.name))
    }
    pub fn f32(&mut self) -> Result<f32, String> {
        Ok(f32::from_bits(self.u32()?))
    }
    pub fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_bits(self.u64()?))
    }
    pub fn f32s<const N: usize>(&mut self) -> Result<[f32; N], String> {
        let mut a = [0.0; N];
        for v in &mut a {
            *v = self.f32()?;
        }
        Ok(a)
    }
    pub fn str(&mut self) -> Result<String, String> {
        let n = self.u32()? as usize;
        let bytes = self.take(n)?;
        String::from_utf8(bytes.to_vec())
            .map_err(|_| format!("section '{}': a string that is not UTF-8", self.name))
    }
    /// A count of items of at least `min_bytes` each, checked against the
    /// bytes left (so that a corrupted count cannot ask for memory).
    pub fn count(&mut self, min_bytes: usize) -> Result<usize, String> {
        let n = self.u32()? as usize;
        if n.saturating_mul(min_bytes.max(1)) > self.bytes.len() - self.at {
            return Err(format!(
                "section '{}': a count of {n} items that its {} bytes cannot hold",
                self.name,
                self.bytes.len()
            ));
        }
        Ok(n)
    }
    /// Whether every byte of the record has been read: a field added at a
    /// record's end in a later raytree is read only where it is there.
    pub fn at_end(&self) -> bool {
        self.at == self.bytes.len()
    }
    /// Checks that the whole record was read.
    pub fn finish(self) -> Result<(), String> {
        if self.at != self.bytes.len() {
            return Err(format!(
                "section '{}' has {} bytes after its last field",
                self.name,
                self.bytes.len() - self.at
            ));
        }
        Ok(())
    }
}

/// One section of a file being read.
pub struct Entry<'a> {
    pub name: String,
    pub elem: u32,
    pub bytes: &'a [u8],
    used: AtomicBool,
}

impl<'a> Entry<'a> {
    pub fn new(name: String, elem: u32, bytes: &'a [u8]) -> Self {
        Entry {
            name,
            elem,
            bytes,
            used: AtomicBool::new(false),
        }
    }
}

/// The sections of a file whose container was checked (bounds, checksums):
/// arrays copied out by name and element type; [`Source::unused`] names a
/// section nobody asked for.
pub struct Source<'a> {
    pub entries: Vec<Entry<'a>>,
}

impl<'a> Source<'a> {
    fn entry(&self, name: &'static str) -> Result<&Entry<'a>, String> {
        let e = self
            .entries
            .iter()
            .find(|e| e.name == name)
            .ok_or_else(|| format!("no section '{name}'"))?;
        e.used.store(true, Ordering::Relaxed);
        Ok(e)
    }

    /// Section `name` as an array of `T`: its element size must be `T`'s
    /// and its length a whole number of them.
    pub fn vec<T: Pod>(&self, name: &'static str) -> Result<Vec<T>, String> {
        let e = self.entry(name)?;
        let size = std::mem::size_of::<T>();
        if e.elem as usize != size || e.bytes.len() % size != 0 {
            return Err(format!(
                "section '{name}' holds {} bytes of {}-byte elements where {size}-byte elements are expected",
                e.bytes.len(),
                e.elem
            ));
        }
        Ok(match bytemuck::try_cast_slice::<u8, T>(e.bytes) {
            Ok(s) => s.to_vec(),
            // An unaligned buffer (bytes in memory, not a mapping).
            Err(_) => bytemuck::pod_collect_to_vec(e.bytes),
        })
    }

    /// Section `name` as an array of `T`, borrowed where the bytes are
    /// aligned for `T` (a mapped file) and copied otherwise, handed to `f`.
    pub fn with<T: Pod, R>(
        &self,
        name: &'static str,
        f: impl FnOnce(&[T]) -> R,
    ) -> Result<R, String> {
        let e = self.entry(name)?;
        let size = std::mem::size_of::<T>();
        if e.elem as usize != size || e.bytes.len() % size != 0 {
            return Err(format!(
                "section '{name}' holds {} bytes of {}-byte elements where {size}-byte elements are expected",
                e.bytes.len(),
                e.elem
            ));
        }
        Ok(match bytemuck::try_cast_slice::<u8, T>(e.bytes) {
            Ok(s) => f(s),
            Err(_) => f(&bytemuck::pod_collect_to_vec::<u8, T>(e.bytes)),
        })
    }

    /// Section `name` as a record.
    pub fn record(&self, name: &'static str) -> Result<RecordReader<'a>, String> {
        let e = self.entry(name)?;
        if e.elem != 1 {
            return Err(format!("section '{name}' is not a record"));
        }
        Ok(RecordReader::new(name, e.bytes))
    }

    /// The first section no loader asked for.
    pub fn unused(&self) -> Option<&str> {
        self.entries
            .iter()
            .find(|e| !e.used.load(Ordering::Relaxed))
            .map(|e| e.name.as_str())
    }
}

/// Checks a sign-terminated leaf run ([`crate::structures::LAST`]) that
/// starts at `first` in `index`: it ends inside `index`, and every triangle
/// it names is below `triangles`. Returns the run's length.
pub fn leaf_run(index: &[u32], first: u32, triangles: usize, what: &str) -> Result<usize, String> {
    use crate::structures::LAST;
    let run = index
        .get(first as usize..)
        .filter(|r| !r.is_empty())
        .ok_or_else(|| {
            format!(
                "{what}: leaf at index-list position {first}, past the list's {} entries",
                index.len()
            )
        })?;
    if first > 0 && index[first as usize - 1] & LAST == 0 {
        return Err(format!(
            "{what}: a leaf begins at index-list position {first}, inside another leaf's run"
        ));
    }
    for (k, &e) in run.iter().enumerate() {
        if (e & !LAST) as usize >= triangles {
            return Err(format!(
                "{what}: index-list entry {} names triangle {}, but the scene has {triangles}",
                first as usize + k,
                e & !LAST
            ));
        }
        if e & LAST != 0 {
            return Ok(k + 1);
        }
    }
    Err(format!(
        "{what}: the leaf at index-list position {first} is not terminated before the list ends"
    ))
}

/// A set of positions below `n`, one bit each.
pub struct Bits(Vec<u64>);

impl Bits {
    pub fn new(n: usize) -> Self {
        Bits(vec![0; n.div_ceil(64)])
    }
    /// Sets bit `i`; whether it was clear.
    pub fn insert(&mut self, i: usize) -> bool {
        let (w, b) = (i / 64, 1u64 << (i % 64));
        let was = self.0[w] & b == 0;
        self.0[w] |= b;
        was
    }
    /// Whether bit `i` is set (false past the end).
    pub fn contains(&self, i: usize) -> bool {
        self.0.get(i / 64).is_some_and(|w| w & (1 << (i % 64)) != 0)
    }
    /// The set positions, ascending.
    pub fn iter(&self) -> impl Iterator<Item = usize> + '_ {
        self.0.iter().enumerate().flat_map(|(w, &bits)| {
            let mut b = bits;
            std::iter::from_fn(move || {
                (b != 0).then(|| {
                    let i = b.trailing_zeros() as usize;
                    b &= b - 1;
                    w * 64 + i
                })
            })
        })
    }
}

/// Checks that a layout's leaves listed for visit logs (`(first, canonical
/// id)`, ascending by `first`) are exactly the leaf starts a walk found.
pub fn leaf_ids_match(
    ids: &[(u32, u32)],
    starts: &Bits,
    leaves: usize,
    what: &str,
) -> Result<(), String> {
    if ids.len() != leaves {
        return Err(format!(
            "{what}: {} leaf ids for {leaves} leaves",
            ids.len()
        ));
    }
    if ids.windows(2).any(|w| w[0].0 >= w[1].0) {
        return Err(format!("{what}: leaf ids out of order"));
    }
    for &(first, _) in ids {
        if !starts.contains(first as usize) {
            return Err(format!(
                "{what}: a leaf id for position {first}, where no leaf starts"
            ));
        }
    }
    Ok(())
}
