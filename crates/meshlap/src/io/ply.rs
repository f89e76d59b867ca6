//! Stanford PLY: `ascii`, `binary_little_endian` and `binary_big_endian`.
//!
//! - `vertex` element: `x`, `y`, `z` of any scalar type (`char`/`int8`, `uchar`/`uint8`,
//!   `short`/`int16`, `ushort`/`uint16`, `int`/`int32`, `uint`/`uint32`,
//!   `float`/`float32`, `double`/`float64`); other properties are skipped.
//! - `face` element: a list property `vertex_indices` or `vertex_index` with any count
//!   and index types; polygons are fan-triangulated.
//! - `tristrips` element: a list `vertex_indices` of triangle strips, `-1` restarting a
//!   strip; strip triangle `t` is `(s_t, s_{t+1}, s_{t+2})` for even `t` and
//!   `(s_{t+1}, s_t, s_{t+2})` for odd `t` (alternating winding), and triangles with a
//!   repeated vertex (used to join strips) are skipped and counted. A binary list of
//!   integer indices is decoded in parallel blocks, its triangles in one pass without
//!   branches on the data (BENCHMARKS.md, "Python API").
//! - Any other element or property, lists included, is skipped in every encoding.
//!
//! Counts from the header are checked against the bytes that remain before anything
//! is allocated.

use super::text::{parse_err, show};
use super::{IoError, ReadInfo, WriteOptions};
use crate::mesh::TriMesh;
use rayon::prelude::*;
use std::io::Write;

#[derive(Copy, Clone, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &[u8]) -> Option<Scalar> {
        Some(match s {
            b"char" | b"int8" => Scalar::I8,
            b"uchar" | b"uint8" => Scalar::U8,
            b"short" | b"int16" => Scalar::I16,
            b"ushort" | b"uint16" => Scalar::U16,
            b"int" | b"int32" => Scalar::I32,
            b"uint" | b"uint32" => Scalar::U32,
            b"float" | b"float32" => Scalar::F32,
            b"double" | b"float64" => Scalar::F64,
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }
}

#[derive(Clone, Debug)]
enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Clone, Debug)]
struct Property {
    name: Vec<u8>,
    kind: Kind,
}

#[derive(Clone, Debug)]
struct Element {
    name: Vec<u8>,
    count: usize,
    props: Vec<Property>,
}

#[derive(Copy, Clone, Debug, PartialEq)]
enum Encoding {
    Ascii,
    Little,
    Big,
}

struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    data_start: usize,
    data_line: usize,
}

fn parse_header(bytes: &[u8], file: &str) -> Result<Header, IoError> {
    let err = |message: String| IoError::Header {
        file: file.to_string(),
        message,
    };
    let mut pos = 0usize;
    let mut line_no = 0usize;
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let rest = &bytes[pos..];
        let end = rest
            .iter()
            .position(|&b| b == b'\n')
            .ok_or_else(|| err("no end_header".into()))?;
        let line = rest[..end].strip_suffix(b"\r").unwrap_or(&rest[..end]);
        pos += end + 1;
        line_no += 1;
        let mut t = super::text::tokens(line);
        let Some(head) = t.next() else { continue };
        if line_no == 1 {
            if head != b"ply" {
                return Err(err("the file does not start with `ply`".into()));
            }
            continue;
        }
        match head {
            b"format" => {
                encoding = Some(match t.next().unwrap_or(b"") {
                    b"ascii" => Encoding::Ascii,
                    b"binary_little_endian" => Encoding::Little,
                    b"binary_big_endian" => Encoding::Big,
                    other => {
                        return Err(err(format!(
                            "line {line_no}: unknown format \"{}\"",
                            show(other)
                        )))
                    }
                });
            }
            b"comment" | b"obj_info" => {}
            b"element" => {
                let name = t
                    .next()
                    .ok_or_else(|| err(format!("line {line_no}: element without a name")))?;
                let count_tok = t.next().unwrap_or(b"");
                let count =
                    super::text::parse_num::<usize>(count_tok, file, line_no, "an element count")?;
                // Face indices refer to the one vertex element (a second one was read
                // into the positions by the record-by-record path and replaced them in
                // the fast path: a finding of the differential fuzz target).
                if name == b"vertex" && elements.iter().any(|e| e.name == b"vertex") {
                    return Err(err(format!("line {line_no}: a second `vertex` element")));
                }
                elements.push(Element {
                    name: name.to_vec(),
                    count,
                    props: Vec::new(),
                });
            }
            b"property" => {
                let el = elements
                    .last_mut()
                    .ok_or_else(|| err(format!("line {line_no}: property before any element")))?;
                let ty = t.next().unwrap_or(b"");
                let kind = if ty == b"list" {
                    let c = t.next().unwrap_or(b"");
                    let i = t.next().unwrap_or(b"");
                    let count = Scalar::parse(c)
                        .ok_or_else(|| parse_err(file, line_no, c, "a PLY scalar type"))?;
                    let item = Scalar::parse(i)
                        .ok_or_else(|| parse_err(file, line_no, i, "a PLY scalar type"))?;
                    if !count.is_integer() {
                        return Err(parse_err(file, line_no, c, "an integer list-count type"));
                    }
                    Kind::List { count, item }
                } else {
                    Kind::Scalar(
                        Scalar::parse(ty)
                            .ok_or_else(|| parse_err(file, line_no, ty, "a PLY scalar type"))?,
                    )
                };
                let name = t
                    .next()
                    .ok_or_else(|| err(format!("line {line_no}: property without a name")))?;
                el.props.push(Property {
                    name: name.to_vec(),
                    kind,
                });
            }
            b"end_header" => break,
            other => {
                return Err(err(format!(
                    "line {line_no}: unexpected \"{}\"",
                    show(other)
                )))
            }
        }
    }
    Ok(Header {
        encoding: encoding.ok_or_else(|| err("no format line".into()))?,
        elements,
        data_start: pos,
        data_line: line_no + 1,
    })
}

/// Source of values: binary cursor or ASCII tokens.
struct Reader<'a> {
    data: &'a [u8],
    pos: usize,
    line: usize,
    enc: Encoding,
    file: &'a str,
}

impl<'a> Reader<'a> {
    fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    fn truncated(&self, what: &str) -> IoError {
        IoError::Truncated {
            file: self.file.to_string(),
            what: what.to_string(),
        }
    }

    /// Line of the next ASCII token (skips whitespace; no-op for binary data).
    fn line_of_next(&mut self) -> usize {
        if self.enc == Encoding::Ascii {
            let d = self.data;
            while self.pos < d.len() && d[self.pos].is_ascii_whitespace() {
                if d[self.pos] == b'\n' {
                    self.line += 1;
                }
                self.pos += 1;
            }
        }
        self.line
    }

    fn next_token(&mut self) -> Option<&'a [u8]> {
        let d = self.data;
        self.line_of_next();
        let start = self.pos;
        while self.pos < d.len() && !d[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        (self.pos > start).then(|| &d[start..self.pos])
    }

    fn value(&mut self, s: Scalar, what: &str) -> Result<f64, IoError> {
        if self.enc == Encoding::Ascii {
            let line = self.line_of_next();
            let tok = self.next_token().ok_or_else(|| self.truncated(what))?;
            let v = super::text::parse_f64(tok);
            return match v {
                Some(v) if !s.is_integer() || v.fract() == 0.0 => Ok(v),
                _ => Err(parse_err(
                    self.file,
                    line,
                    tok,
                    if s.is_integer() {
                        "an integer"
                    } else {
                        "a number"
                    },
                )),
            };
        }
        let n = s.size();
        if self.remaining() < n {
            return Err(self.truncated(what));
        }
        let b = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(decode(b, s, self.enc == Encoding::Little))
    }

    /// Reads a list length and checks it against the remaining data.
    fn list_len(&mut self, count: Scalar, item: Scalar, what: &str) -> Result<usize, IoError> {
        let line = self.line_of_next();
        let c = self.value(count, what)?;
        if c < 0.0 {
            return Err(parse_err(
                self.file,
                line,
                c.to_string().as_bytes(),
                "a list length",
            ));
        }
        let c = c as usize;
        // An ASCII item needs a digit and a separator (the last one may end the file).
        let fits = if self.enc == Encoding::Ascii {
            c.saturating_mul(2) <= self.remaining() + 1
        } else {
            c.saturating_mul(item.size()) <= self.remaining()
        };
        if !fits {
            return Err(self.truncated(what));
        }
        Ok(c)
    }

    fn skip(&mut self, p: &Property, what: &str) -> Result<(), IoError> {
        match p.kind {
            Kind::Scalar(s) => {
                self.value(s, what)?;
            }
            Kind::List { count, item } => {
                let n = self.list_len(count, item, what)?;
                if self.enc == Encoding::Ascii {
                    for _ in 0..n {
                        self.value(item, what)?;
                    }
                } else {
                    self.pos += n * item.size();
                }
            }
        }
        Ok(())
    }
}

/// The binary scalar `s` at the start of `b` (at least `s.size()` bytes), as `f64`.
#[inline(always)]
fn decode(b: &[u8], s: Scalar, little_endian: bool) -> f64 {
    macro_rules! num {
        ($t:ty) => {{
            let mut arr = [0u8; std::mem::size_of::<$t>()];
            arr.copy_from_slice(&b[..std::mem::size_of::<$t>()]);
            (if little_endian {
                <$t>::from_le_bytes(arr)
            } else {
                <$t>::from_be_bytes(arr)
            }) as f64
        }};
    }
    match s {
        Scalar::I8 => b[0] as i8 as f64,
        Scalar::U8 => b[0] as f64,
        Scalar::I16 => num!(i16),
        Scalar::U16 => num!(u16),
        Scalar::I32 => num!(i32),
        Scalar::U32 => num!(u32),
        Scalar::F32 => num!(f32),
        Scalar::F64 => num!(f64),
    }
}

/// Records per parallel task of the binary fast paths.
const RECORDS_PER_TASK: usize = 1 << 14;

/// A binary scalar type read as `f64` in a byte order fixed at compile time, so that
/// the fixed-record loops below are compiled once per (type, byte order) without a
/// per-value dispatch on [`Scalar`] (which [`decode`] has).
trait Bin {
    const SIZE: usize;
    /// The value at the start of `b` (at least `SIZE` bytes), little-endian if `LE`.
    fn get<const LE: bool>(b: &[u8]) -> f64;
}

macro_rules! impl_bin {
    ($($t:ty),*) => {$(
        impl Bin for $t {
            const SIZE: usize = std::mem::size_of::<$t>();
            #[inline(always)]
            fn get<const LE: bool>(b: &[u8]) -> f64 {
                let mut arr = [0u8; std::mem::size_of::<$t>()];
                arr.copy_from_slice(&b[..std::mem::size_of::<$t>()]);
                (if LE { <$t>::from_le_bytes(arr) } else { <$t>::from_be_bytes(arr) }) as f64
            }
        }
    )*};
}
impl_bin!(i8, u8, i16, u16, i32, u32, f32, f64);

/// Runs `$body` with the type alias `$T` bound to the Rust type of scalar `$s`.
macro_rules! with_scalar {
    ($s:expr, $T:ident => $body:expr) => {
        match $s {
            Scalar::I8 => {
                type $T = i8;
                $body
            }
            Scalar::U8 => {
                type $T = u8;
                $body
            }
            Scalar::I16 => {
                type $T = i16;
                $body
            }
            Scalar::U16 => {
                type $T = u16;
                $body
            }
            Scalar::I32 => {
                type $T = i32;
                $body
            }
            Scalar::U32 => {
                type $T = u32;
                $body
            }
            Scalar::F32 => {
                type $T = f32;
                $body
            }
            Scalar::F64 => {
                type $T = f64;
                $body
            }
        }
    };
}

/// Byte layout of a fixed-size binary record: its size and, for each of three values,
/// its offset and type.
#[derive(Copy, Clone)]
struct Layout {
    stride: usize,
    at: [(usize, Scalar); 3],
}

/// Binary fast path for a `vertex` element whose properties are all scalars (fixed-size
/// records): decodes x, y, z (property indices `idx`) of `count` records at the start
/// of `data` in parallel, blocks of records decoded straight into the output. `None`
/// when the element has a list property or `data` is too short; `Some(Err(v))` names
/// the first vertex with a NaN or infinite coordinate. When x, y and z have one type
/// (the usual `float` or `double`), the loop is the one compiled for that type and
/// byte order; mixed types go through [`decode`].
#[allow(clippy::type_complexity)]
fn fixed_vertices(
    data: &[u8],
    el: &Element,
    idx: [usize; 3],
    little_endian: bool,
    per_task: usize,
) -> Option<Result<(Vec<[f64; 3]>, usize), usize>> {
    let mut offsets = Vec::with_capacity(el.props.len());
    let mut stride = 0;
    for p in &el.props {
        let Kind::Scalar(s) = p.kind else { return None };
        offsets.push((stride, s));
        stride += s.size();
    }
    let layout = Layout {
        stride,
        at: idx.map(|i| offsets[i]),
    };
    let bytes = el.count.checked_mul(stride)?;
    let data = data.get(..bytes)?;
    let s = layout.at[0].1;
    // x, y and z are properties of the record, so `stride` is at least 3.
    let positions = if layout.at.iter().all(|&(_, t)| t == s) {
        with_scalar!(s, T => if little_endian {
            vertices_as::<T, true>(data, layout, el.count, per_task)
        } else {
            vertices_as::<T, false>(data, layout, el.count, per_task)
        })
    } else {
        let at = layout.at;
        vertices_with(data, stride, el.count, per_task, |rec| {
            at.map(|(o, s)| decode(&rec[o..], s, little_endian))
        })
    };
    Some(positions.map(|p| (p, bytes)))
}

/// [`vertices_with`] for x, y, z of type `T`, with a separate loop for the packed
/// record `x y z` (no other property), whose offsets are then constants.
fn vertices_as<T: Bin, const LE: bool>(
    data: &[u8],
    layout: Layout,
    n: usize,
    per_task: usize,
) -> Result<Vec<[f64; 3]>, usize> {
    let [(ox, _), (oy, _), (oz, _)] = layout.at;
    if layout.stride == 3 * T::SIZE && [ox, oy, oz] == [0, T::SIZE, 2 * T::SIZE] {
        vertices_with(data, 3 * T::SIZE, n, per_task, |rec| {
            [
                T::get::<LE>(rec),
                T::get::<LE>(&rec[T::SIZE..]),
                T::get::<LE>(&rec[2 * T::SIZE..]),
            ]
        })
    } else {
        vertices_with(data, layout.stride, n, per_task, |rec| {
            [
                T::get::<LE>(&rec[ox..]),
                T::get::<LE>(&rec[oy..]),
                T::get::<LE>(&rec[oz..]),
            ]
        })
    }
}

/// Decodes `n` records of `stride` bytes (`data` holds exactly that) with `xyz`, in
/// parallel blocks of `per_task` records (at least 1; [`RECORDS_PER_TASK`] in
/// [`read`]) written in place; `Err(v)` names the first vertex with a NaN or infinite
/// coordinate.
#[inline(always)]
fn vertices_with(
    data: &[u8],
    stride: usize,
    n: usize,
    per_task: usize,
    xyz: impl Fn(&[u8]) -> [f64; 3] + Sync,
) -> Result<Vec<[f64; 3]>, usize> {
    let per_task = per_task.max(1);
    let mut out = crate::mem::zeroed_vec([0.0f64; 3], n);
    let bad = out
        .par_chunks_mut(per_task)
        .zip(data.par_chunks(per_task * stride))
        .enumerate()
        .filter_map(|(k, (out, data))| {
            let mut finite = true;
            for (p, rec) in out.iter_mut().zip(data.chunks_exact(stride)) {
                *p = xyz(rec);
                finite &= p[0].is_finite() & p[1].is_finite() & p[2].is_finite();
            }
            if finite {
                return None;
            }
            let v = out.iter().position(|p| !p.iter().all(|c| c.is_finite()))?;
            Some(k * per_task + v)
        })
        .min();
    match bad {
        Some(v) => Err(v),
        None => Ok(out),
    }
}

/// Binary fast path for a `face` element whose records all hold a triangle: every
/// property a scalar except the list `li`, and every list of length 3, so records have
/// one size. Decodes and range-checks the triangles in parallel blocks written in
/// place; the usual count and index types (`uchar`, `int`, `uint` counts of `int` or
/// `uint` indices) have loops compiled for them, others go through [`decode`]. `None`
/// when the layout differs or any record does not fit (a polygon, an index out of
/// range): the caller then reads the element sequentially, which reports the exact
/// error.
fn fixed_triangles(
    data: &[u8],
    el: &Element,
    li: usize,
    n_vertices: usize,
    little_endian: bool,
    per_task: usize,
) -> Option<(Vec<[u32; 3]>, usize)> {
    let mut stride = 0;
    let mut list_at = (0, Scalar::U8, Scalar::I32);
    for (k, p) in el.props.iter().enumerate() {
        match p.kind {
            Kind::Scalar(s) => stride += s.size(),
            Kind::List { count, item } if k == li => {
                list_at = (stride, count, item);
                stride += count.size() + 3 * item.size();
            }
            Kind::List { .. } => return None,
        }
    }
    let (at, count, item) = list_at;
    let bytes = el.count.checked_mul(stride)?;
    let data = data.get(..bytes)?;
    let nv = n_vertices as f64;
    let first = at + count.size();
    macro_rules! typed {
        ($C:ty, $I:ty, $LE:literal) => {
            triangles_with(data, stride, el.count, per_task, |rec| {
                let rec = &rec[at..];
                if <$C>::get::<$LE>(rec) != 3.0 {
                    return None;
                }
                let rec = &rec[<$C>::SIZE..];
                let t = [
                    <$I>::get::<$LE>(rec),
                    <$I>::get::<$LE>(&rec[<$I>::SIZE..]),
                    <$I>::get::<$LE>(&rec[2 * <$I>::SIZE..]),
                ];
                // NaN (a float index) fails the test too.
                t.iter()
                    .all(|&x| x >= 0.0 && x < nv)
                    .then(|| t.map(|x| x as u32))
            })
        };
    }
    let faces = match (count, item, little_endian) {
        (Scalar::U8, Scalar::I32, true) => typed!(u8, i32, true),
        (Scalar::U8, Scalar::U32, true) => typed!(u8, u32, true),
        (Scalar::I32, Scalar::I32, true) => typed!(i32, i32, true),
        (Scalar::U32, Scalar::U32, true) => typed!(u32, u32, true),
        (Scalar::U8, Scalar::I32, false) => typed!(u8, i32, false),
        (Scalar::U8, Scalar::U32, false) => typed!(u8, u32, false),
        (Scalar::I32, Scalar::I32, false) => typed!(i32, i32, false),
        (Scalar::U32, Scalar::U32, false) => typed!(u32, u32, false),
        _ => triangles_with(data, stride, el.count, per_task, |rec| {
            if decode(&rec[at..], count, little_endian) != 3.0 {
                return None;
            }
            let mut t = [0u32; 3];
            for (c, v) in t.iter_mut().enumerate() {
                let x = decode(&rec[first + c * item.size()..], item, little_endian);
                if !(x >= 0.0 && x < nv) {
                    return None;
                }
                *v = x as u32;
            }
            Some(t)
        }),
    }?;
    Some((faces, bytes))
}

/// Decodes `n` records of `stride` bytes (`data` holds exactly that) with `triangle`,
/// in parallel blocks of `per_task` records (at least 1) written in place; `None` as
/// soon as one record gives `None`.
#[inline(always)]
fn triangles_with(
    data: &[u8],
    stride: usize,
    n: usize,
    per_task: usize,
    triangle: impl Fn(&[u8]) -> Option<[u32; 3]> + Sync,
) -> Option<Vec<[u32; 3]>> {
    if stride == 0 {
        return None;
    }
    let per_task = per_task.max(1);
    let mut out = crate::mem::zeroed_vec([0u32; 3], n);
    let fits = out
        .par_chunks_mut(per_task)
        .zip(data.par_chunks(per_task * stride))
        .all(|(out, data)| {
            out.iter_mut()
                .zip(data.chunks_exact(stride))
                .all(|(t, rec)| match triangle(rec) {
                    Some(v) => {
                        *t = v;
                        true
                    }
                    None => false,
                })
        });
    fits.then_some(out)
}

fn min_element_bytes(el: &Element, enc: Encoding) -> usize {
    el.props
        .iter()
        .map(|p| match (enc, &p.kind) {
            (Encoding::Ascii, _) => 2,
            (_, Kind::Scalar(s)) => s.size(),
            (_, Kind::List { count, .. }) => count.size(),
        })
        .sum()
}

pub(crate) fn read(bytes: &[u8], file: &str, info: &mut ReadInfo) -> Result<TriMesh, IoError> {
    read_with(bytes, file, info, Some(RECORDS_PER_TASK))
}

/// [`read`] with the binary fixed-record fast paths decoding parallel blocks of
/// `fixed = Some(records)` records (tests and the differential fuzz target cut small
/// files finely); `fixed: None` reads binary elements record by record, without the
/// fast paths (the reference they are compared with).
pub(super) fn read_with(
    bytes: &[u8],
    file: &str,
    info: &mut ReadInfo,
    fixed: Option<usize>,
) -> Result<TriMesh, IoError> {
    let h = parse_header(bytes, file)?;
    let mut r = Reader {
        data: bytes,
        pos: h.data_start,
        line: h.data_line,
        enc: h.encoding,
        file,
    };
    let nv = h
        .elements
        .iter()
        .find(|e| e.name == b"vertex")
        .map_or(0, |e| e.count);
    let mut positions: Vec<[f64; 3]> = Vec::new();
    let mut faces: Vec<[u32; 3]> = Vec::new();
    let mut poly: Vec<u32> = Vec::new();
    for el in &h.elements {
        let need = el.count.saturating_mul(min_element_bytes(el, h.encoding));
        if need > r.remaining() {
            return Err(IoError::Header {
                file: file.to_string(),
                message: format!(
                    "element `{}` claims {} entries, at least {need} bytes, but only {} remain",
                    show(&el.name),
                    el.count,
                    r.remaining()
                ),
            });
        }
        let what = format!("element `{}`", show(&el.name));
        match el.name.as_slice() {
            b"vertex" => {
                let find = |n: &[u8]| el.props.iter().position(|p| p.name == n);
                let idx = [find(b"x"), find(b"y"), find(b"z")];
                if idx.iter().any(|i| i.is_none()) {
                    return Err(IoError::Unsupported {
                        file: file.to_string(),
                        message: "vertex element without x, y and z".into(),
                    });
                }
                let idx = idx.map(|i| i.unwrap_or(0));
                if let (Some(per_task), false) = (fixed, h.encoding == Encoding::Ascii) {
                    let little = h.encoding == Encoding::Little;
                    let found = fixed_vertices(&bytes[r.pos..], el, idx, little, per_task);
                    if let Some(fixed) = found {
                        let (p, used) = fixed.map_err(|v| IoError::NonFinite {
                            file: file.to_string(),
                            line: 0,
                            vertex: v,
                        })?;
                        positions = p;
                        r.pos += used;
                        continue;
                    }
                }
                positions.reserve(el.count);
                for v in 0..el.count {
                    let mut p = [0.0; 3];
                    let line = r.line_of_next();
                    for (k, prop) in el.props.iter().enumerate() {
                        match (idx.iter().position(|&i| i == k), &prop.kind) {
                            (Some(c), Kind::Scalar(s)) => p[c] = r.value(*s, &what)?,
                            (Some(_), Kind::List { .. }) => {
                                return Err(IoError::Unsupported {
                                    file: file.to_string(),
                                    message: "a list-valued coordinate".into(),
                                })
                            }
                            (None, _) => r.skip(prop, &what)?,
                        }
                    }
                    if !p.iter().all(|c| c.is_finite()) {
                        return Err(IoError::NonFinite {
                            file: file.to_string(),
                            line: if h.encoding == Encoding::Ascii {
                                line
                            } else {
                                0
                            },
                            vertex: v,
                        });
                    }
                    positions.push(p);
                }
            }
            b"face" | b"tristrips" => {
                let strips = el.name == b"tristrips";
                let li = el.props.iter().position(|p| {
                    matches!(p.kind, Kind::List { .. })
                        && (p.name == b"vertex_indices" || (!strips && p.name == b"vertex_index"))
                });
                let Some(li) = li else {
                    return Err(IoError::Unsupported {
                        file: file.to_string(),
                        message: format!("{what} has no vertex_indices list"),
                    });
                };
                if let (Some(per_task), false) = (fixed, strips || h.encoding == Encoding::Ascii) {
                    let little = h.encoding == Encoding::Little;
                    let found = fixed_triangles(&bytes[r.pos..], el, li, nv, little, per_task);
                    if let Some((f, used)) = found {
                        if faces.is_empty() {
                            faces = f;
                        } else {
                            faces.extend_from_slice(&f);
                        }
                        r.pos += used;
                        continue;
                    }
                }
                if !strips {
                    faces.reserve(el.count);
                }
                for _ in 0..el.count {
                    for (k, prop) in el.props.iter().enumerate() {
                        if k != li {
                            r.skip(prop, &what)?;
                            continue;
                        }
                        let Kind::List { count, item } = prop.kind else {
                            continue;
                        };
                        let line = r.line_of_next();
                        let n = r.list_len(count, item, &what)?;
                        poly.clear();
                        if let (true, Some(per_task), false) =
                            (strips, fixed, h.encoding == Encoding::Ascii)
                        {
                            let little = h.encoding == Encoding::Little;
                            let data = &bytes[r.pos..r.pos + n * item.size()];
                            if let Some(found) =
                                strip_items(data, item, little, nv, per_task, &mut poly)
                            {
                                found.map_err(|index| IoError::IndexOutOfRange {
                                    file: file.to_string(),
                                    line: 0,
                                    index,
                                    vertices: nv,
                                })?;
                                r.pos += data.len();
                                strip_triangles(&poly, &mut faces, info);
                                continue;
                            }
                        }
                        for _ in 0..n {
                            let x = r.value(item, &what)?;
                            if strips && x == -1.0 {
                                poly.push(u32::MAX);
                                continue;
                            }
                            // NaN (a float index) is out of range too.
                            if !(x >= 0.0 && x < nv as f64) {
                                return Err(IoError::IndexOutOfRange {
                                    file: file.to_string(),
                                    line: if h.encoding == Encoding::Ascii {
                                        line
                                    } else {
                                        0
                                    },
                                    index: x as i64,
                                    vertices: nv,
                                });
                            }
                            poly.push(x as u32);
                        }
                        if strips {
                            strip_triangles(&poly, &mut faces, info);
                        } else {
                            if n < 3 {
                                return Err(IoError::Unsupported {
                                    file: file.to_string(),
                                    message: format!("a face with {n} vertices"),
                                });
                            }
                            if super::text::fan(&poly, &mut faces) {
                                info.polygons_triangulated += 1;
                            }
                        }
                    }
                }
            }
            // An element without properties holds no data, whatever its count (a
            // hostile count of 10^18 would otherwise spin here).
            _ if el.props.is_empty() => {}
            _ => {
                for _ in 0..el.count {
                    for prop in &el.props {
                        r.skip(prop, &what)?;
                    }
                }
            }
        }
    }
    Ok(TriMesh::new(positions, faces))
}

/// The items of one binary `tristrips` list (`data`: its items, `item` each) as
/// vertex indices in `out`, `u32::MAX` for each restart (`-1`), decoded in parallel
/// blocks of `per_task` items (at least 1). `Some(Err(index))` names the first index
/// outside `0..nv`, as the item-by-item read would; `None` for a floating-point item
/// type, which the item-by-item read handles.
fn strip_items(
    data: &[u8],
    item: Scalar,
    little_endian: bool,
    nv: usize,
    per_task: usize,
    out: &mut Vec<u32>,
) -> Option<Result<(), i64>> {
    fn typed<T: Bin, const LE: bool>(
        data: &[u8],
        nv: usize,
        per_task: usize,
        out: &mut Vec<u32>,
    ) -> Result<(), i64> {
        let per_task = per_task.max(1);
        let nv = nv as f64;
        let block = |out: &mut [u32], data: &[u8]| -> Option<i64> {
            for (o, b) in out.iter_mut().zip(data.chunks_exact(T::SIZE)) {
                let x = T::get::<LE>(b);
                *o = if x == -1.0 {
                    u32::MAX
                } else if x >= 0.0 && x < nv {
                    x as u32
                } else {
                    return Some(x as i64);
                };
            }
            None
        };
        out.resize(data.len() / T::SIZE, 0);
        let bad = if out.len() <= per_task {
            block(out, data)
        } else {
            // The first bad block's first bad item: blocks are in order.
            out.par_chunks_mut(per_task)
                .zip(data.par_chunks(per_task * T::SIZE))
                .map(|(o, d)| block(o, d))
                .collect::<Vec<_>>()
                .into_iter()
                .flatten()
                .next()
        };
        bad.map_or(Ok(()), Err)
    }
    Some(match (item, little_endian) {
        (Scalar::I8, _) => typed::<i8, true>(data, nv, per_task, out),
        (Scalar::U8, _) => typed::<u8, true>(data, nv, per_task, out),
        (Scalar::I16, true) => typed::<i16, true>(data, nv, per_task, out),
        (Scalar::I16, false) => typed::<i16, false>(data, nv, per_task, out),
        (Scalar::U16, true) => typed::<u16, true>(data, nv, per_task, out),
        (Scalar::U16, false) => typed::<u16, false>(data, nv, per_task, out),
        (Scalar::I32, true) => typed::<i32, true>(data, nv, per_task, out),
        (Scalar::I32, false) => typed::<i32, false>(data, nv, per_task, out),
        (Scalar::U32, true) => typed::<u32, true>(data, nv, per_task, out),
        (Scalar::U32, false) => typed::<u32, false>(data, nv, per_task, out),
        (Scalar::F32 | Scalar::F64, _) => return None,
    })
}

/// Triangles of one `tristrips` list (`u32::MAX` marks a restart): the candidate at
/// item `i` is strip triangle `t = i − s`, `s` the first item of its strip. One pass
/// without branches on the data: every candidate is written to the next free slot,
/// which advances only when the candidate is a triangle (strips are a few items long,
/// so a branch per item would often be mispredicted).
fn strip_triangles(list: &[u32], faces: &mut Vec<[u32; 3]>, info: &mut ReadInfo) {
    const END: u32 = u32::MAX;
    let base = faces.len();
    faces.reserve(list.len().saturating_sub(2));
    let spare = &mut faces.spare_capacity_mut()[..list.len().saturating_sub(2)];
    let (mut start, mut made, mut skipped) = (0usize, 0usize, 0usize);
    for (i, w) in list.windows(3).enumerate() {
        let (a, b, c) = (w[0], w[1], w[2]);
        let odd = (i - start) & 1 == 1; // start ≤ i: it moves to i + 1 after item i
        spare[made].write(if odd { [b, a, c] } else { [a, b, c] });
        let whole = a != END && b != END && c != END;
        let distinct = a != b && b != c && a != c;
        made += usize::from(whole & distinct);
        skipped += usize::from(whole & !distinct);
        start = if a == END { i + 1 } else { start };
    }
    // SAFETY: slots `0..made` of the spare capacity were written above: iteration `i`
    // writes slot `made ≤ i < spare.len()` before possibly advancing `made`.
    unsafe { faces.set_len(base + made) };
    info.triangles_from_strips += made;
    info.degenerate_strip_triangles_skipped += skipped;
}

pub(crate) fn write(w: &mut dyn Write, mesh: &TriMesh, opts: &WriteOptions) -> std::io::Result<()> {
    let ascii = opts.ply_ascii;
    writeln!(w, "ply")?;
    writeln!(
        w,
        "format {} 1.0",
        if ascii {
            "ascii"
        } else {
            "binary_little_endian"
        }
    )?;
    writeln!(w, "comment written by meshlap")?;
    writeln!(w, "element vertex {}", mesh.n_vertices())?;
    for c in ["x", "y", "z"] {
        writeln!(w, "property double {c}")?;
    }
    if let Some((name, _)) = opts.vertex_scalar {
        writeln!(w, "property double {name}")?;
    }
    if opts.vertex_colors.is_some() {
        for c in ["red", "green", "blue"] {
            writeln!(w, "property uchar {c}")?;
        }
    }
    writeln!(w, "element face {}", mesh.n_faces())?;
    writeln!(w, "property list uchar int vertex_indices")?;
    writeln!(w, "end_header")?;
    let (scalar, colors) = (opts.vertex_scalar.map(|(_, s)| s), opts.vertex_colors);
    let p = &mesh.positions;
    super::encode::write_records(w, p.len(), |r, out| {
        let mut t = super::encode::Text::new();
        for v in r {
            if ascii {
                t.floats(out, &p[v]);
                if let Some(s) = scalar {
                    out.push(b' ');
                    t.float(out, s[v]);
                }
                if let Some(c) = colors {
                    for x in c[v] {
                        out.push(b' ');
                        t.int(out, x);
                    }
                }
                out.push(b'\n');
            } else {
                for x in p[v] {
                    out.extend_from_slice(&x.to_le_bytes());
                }
                if let Some(s) = scalar {
                    out.extend_from_slice(&s[v].to_le_bytes());
                }
                if let Some(c) = colors {
                    out.extend_from_slice(&c[v]);
                }
            }
        }
    })?;
    let f = &mesh.faces;
    super::encode::write_records(w, f.len(), |r, out| {
        let mut t = super::encode::Text::new();
        for &face in &f[r] {
            if ascii {
                t.face_line(out, b"3 ", face, 0);
            } else {
                out.push(3);
                for i in face {
                    out.extend_from_slice(&(i as i32).to_le_bytes());
                }
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(b: &[u8]) -> Result<(TriMesh, ReadInfo), IoError> {
        crate::io::read_any(b, crate::io::Format::Ply, "t.ply")
    }

    /// A binary little-endian PLY with float x, y, z, a uchar and a float property per
    /// vertex, and faces `flags (uchar), vertex_indices (uchar count, int items)`.
    fn binary_with_props(faces: &[&[i32]]) -> Vec<u8> {
        let mut b = format!(
            "ply\nformat binary_little_endian 1.0\nelement vertex 5\nproperty float x\nproperty uchar q\nproperty float y\nproperty float z\nproperty float w\nelement face {}\nproperty uchar flags\nproperty list uchar int vertex_indices\nend_header\n",
            faces.len()
        )
        .into_bytes();
        for v in 0..5 {
            b.extend_from_slice(&(v as f32).to_le_bytes());
            b.push(7);
            b.extend_from_slice(&(v as f32 * 0.5).to_le_bytes());
            b.extend_from_slice(&(-(v as f32)).to_le_bytes());
            b.extend_from_slice(&9f32.to_le_bytes());
        }
        for f in faces {
            b.push(1);
            b.push(f.len() as u8);
            for i in *f {
                b.extend_from_slice(&i.to_le_bytes());
            }
        }
        b
    }

    /// A binary PLY of `nv` vertices (coordinates of type `coord`, an extra `uchar`
    /// between y and z when `extra`) and `faces` (list `uchar` count, `item` indices).
    fn big_binary(
        big: bool,
        coord: &str,
        extra: bool,
        item: &str,
        nv: usize,
        faces: &[Vec<i64>],
    ) -> Vec<u8> {
        let mut b = format!(
            "ply\nformat {} 1.0\nelement vertex {nv}\nproperty {coord} x\nproperty {coord} y\n{}property {coord} z\nelement face {}\nproperty list uchar {item} vertex_indices\nend_header\n",
            if big { "binary_big_endian" } else { "binary_little_endian" },
            if extra { "property uchar q\n" } else { "" },
            faces.len()
        )
        .into_bytes();
        let put = |b: &mut Vec<u8>, x: f64, ty: &str| {
            let bytes = match ty {
                "float" => (x as f32).to_le_bytes().to_vec(),
                "double" => x.to_le_bytes().to_vec(),
                "short" => (x as i16).to_le_bytes().to_vec(),
                "int" => (x as i32).to_le_bytes().to_vec(),
                "uint" => (x as u32).to_le_bytes().to_vec(),
                _ => unreachable!(),
            };
            b.extend(
                bytes
                    .iter()
                    .rev()
                    .filter(|_| big)
                    .chain(bytes.iter().filter(|_| !big)),
            );
        };
        for v in 0..nv {
            put(&mut b, v as f64 * 0.25, coord);
            put(&mut b, -(v as f64) * 0.5, coord);
            if extra {
                b.push(v as u8);
            }
            put(&mut b, (v % 7) as f64, coord);
        }
        for f in faces {
            b.push(f.len() as u8);
            for &i in f {
                put(&mut b, i as f64, item);
            }
        }
        b
    }

    fn read_fixed(b: &[u8], fixed: Option<usize>) -> Result<(TriMesh, ReadInfo), String> {
        let mut info = ReadInfo::new(crate::io::Format::Ply);
        read_with(b, "t.ply", &mut info, fixed)
            .map(|m| (m, info))
            .map_err(|e| e.to_string())
    }

    fn read_both(b: &[u8]) -> [Result<(TriMesh, ReadInfo), String>; 2] {
        [Some(RECORDS_PER_TASK), None].map(|fixed| read_fixed(b, fixed))
    }

    #[test]
    fn fixed_record_paths_equal_the_record_by_record_read_across_blocks() {
        // More records than three parallel blocks, so blocks end mid-file; a
        // non-finite coordinate and a bad face in a later block.
        let nv = 2 * RECORDS_PER_TASK + 1234;
        let tri: Vec<Vec<i64>> = (0..3 * RECORDS_PER_TASK as i64 + 77)
            .map(|k| {
                vec![
                    k % nv as i64,
                    (k * 7 + 1) % nv as i64,
                    (k * 13 + 5) % nv as i64,
                ]
            })
            .collect();
        for big in [false, true] {
            for coord in ["float", "double", "short"] {
                for extra in [false, true] {
                    for item in ["int", "uint"] {
                        let b = big_binary(big, coord, extra, item, nv, &tri);
                        let [fast, slow] = read_both(&b);
                        assert_eq!(fast, slow, "{big} {coord} {extra} {item}");
                        let (m, info) = fast.unwrap();
                        assert_eq!((m.n_vertices(), m.n_faces()), (nv, tri.len()));
                        assert_eq!(info.polygons_triangulated, 0);
                    }
                }
            }
        }
        // A quad in the last block: the sequential path reads the element.
        let mut poly = tri.clone();
        poly.last_mut().unwrap().push(3);
        let [fast, slow] = read_both(&big_binary(false, "float", false, "int", nv, &poly));
        assert_eq!(fast, slow);
        assert_eq!(fast.unwrap().1.polygons_triangulated, 1);
        // An index out of range in a later block: the sequential path's error.
        let mut bad = tri.clone();
        bad[2 * RECORDS_PER_TASK + 5][1] = nv as i64;
        let [fast, slow] = read_both(&big_binary(true, "double", true, "int", nv, &bad));
        assert_eq!(fast, slow);
        assert!(fast
            .unwrap_err()
            .contains(&format!("face index {nv} is out of range")));
        // The first non-finite vertex, in a later block, is named.
        let mut b = big_binary(false, "double", false, "int", nv, &tri);
        let header = b.len() - nv * 24 - tri.len() * 13;
        for v in [2 * RECORDS_PER_TASK + 3, 2 * RECORDS_PER_TASK + 1000] {
            b[header + v * 24 + 8..header + v * 24 + 16].copy_from_slice(&f64::NAN.to_le_bytes());
        }
        let [fast, slow] = read_both(&b);
        assert_eq!(fast, slow);
        assert_eq!(
            fast.unwrap_err(),
            format!(
                "t.ply:0: vertex {} has a NaN or infinite coordinate",
                2 * RECORDS_PER_TASK + 3
            )
        );
    }

    #[test]
    fn fixed_record_paths_agree_on_the_fuzz_corpus() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../tests/data/fuzz/ply_binary");
        let mut n = 0;
        for entry in std::fs::read_dir(dir).unwrap() {
            let b = std::fs::read(entry.unwrap().path()).unwrap();
            let [fast, slow] = read_both(&b);
            assert_eq!(fast, slow);
            n += 1;
        }
        assert!(n >= 3);
    }

    #[test]
    fn small_blocks_equal_the_record_by_record_read() {
        // Blocks of 1..=9 records on a small file: block ends fall everywhere, and the
        // failing record (a non-finite vertex, an index out of range) is found in a
        // later block but reported as the sequential read reports it.
        let nv = 23;
        let tri: Vec<Vec<i64>> = (0..31)
            .map(|k| vec![k % nv, (k * 7 + 1) % nv, (k * 13 + 5) % nv])
            .collect();
        let mut bad_face = tri.clone();
        bad_face[17][2] = nv;
        let mut quad = tri.clone();
        quad[29].push(4);
        let mut files = Vec::new();
        for big in [false, true] {
            for coord in ["float", "short"] {
                files.push(big_binary(big, coord, big, "int", nv as usize, &tri));
            }
        }
        files.push(big_binary(
            false,
            "double",
            false,
            "uint",
            nv as usize,
            &bad_face,
        ));
        files.push(big_binary(true, "float", true, "int", nv as usize, &quad));
        let mut nan = big_binary(false, "double", false, "int", nv as usize, &tri);
        let header = nan.len() - nv as usize * 24 - tri.len() * 13;
        for v in [13, 19] {
            nan[header + v * 24..header + v * 24 + 8].copy_from_slice(&f64::NAN.to_le_bytes());
        }
        files.push(nan);
        for (k, b) in files.iter().enumerate() {
            let reference = read_fixed(b, None);
            for per_task in 0..=9 {
                assert_eq!(
                    read_fixed(b, Some(per_task)),
                    reference,
                    "file {k}, {per_task}"
                );
            }
        }
        assert!(read_fixed(&files[4], None)
            .unwrap_err()
            .contains("face index 23"));
        assert!(read_fixed(&files[6], None)
            .unwrap_err()
            .contains("vertex 13"));
        assert_eq!(
            read_fixed(&files[5], None).unwrap().1.polygons_triangulated,
            1
        );
    }

    #[test]
    fn a_second_vertex_element_is_refused() {
        // Found by the differential fuzz target: the record-by-record read appended
        // the second element's positions, the binary fast path kept only them.
        let head = "element vertex 1\nproperty float x\nproperty float y\nproperty float z\n";
        let file = |format: &str, body: &[u8]| {
            let mut b = format!(
                "ply\nformat {format} 1.0\n{head}{head}element face 1\n\
                 property list uchar int vertex_indices\nend_header\n"
            )
            .into_bytes();
            b.extend_from_slice(body);
            b
        };
        let mut body = Vec::new();
        for v in [[0f32, 0., 0.], [1., 0., 0.]] {
            for c in v {
                body.extend_from_slice(&c.to_le_bytes());
            }
        }
        body.push(3);
        for i in [0i32, 1, 0] {
            body.extend_from_slice(&i.to_le_bytes());
        }
        for b in [
            file("binary_little_endian", &body),
            file("ascii", b"0 0 0\n1 0 0\n3 0 1 0\n"),
        ] {
            for fixed in [Some(RECORDS_PER_TASK), Some(1), None] {
                let e = read_fixed(&b, fixed).unwrap_err();
                assert_eq!(
                    e, "t.ply: bad header: line 7: a second `vertex` element",
                    "{fixed:?}"
                );
            }
        }
    }

    #[test]
    fn huge_count_of_an_element_without_properties_is_read_at_once() {
        // Found while writing the fuzz harness: 10^18 empty entries spun the reader.
        let b = b"ply\nformat ascii 1.0\nelement nothing 1000000000000000000\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        assert_eq!(parse(b).unwrap().0.faces, vec![[0, 1, 2]]);
    }

    #[test]
    fn binary_fast_paths_and_their_fallbacks() {
        // All triangles: the fixed-record paths.
        let (m, info) = parse(&binary_with_props(&[&[0, 1, 2], &[2, 3, 4]])).unwrap();
        assert_eq!(m.positions[3], [3.0, 1.5, -3.0]);
        assert_eq!(m.faces, vec![[0, 1, 2], [2, 3, 4]]);
        assert_eq!(info.polygons_triangulated, 0);
        // A quad among triangles: the record sizes differ, the sequential path reads it.
        let (m, info) =
            parse(&binary_with_props(&[&[0, 1, 2], &[1, 2, 3, 4], &[0, 2, 4]])).unwrap();
        assert_eq!(m.faces, vec![[0, 1, 2], [1, 2, 3], [1, 3, 4], [0, 2, 4]]);
        assert_eq!(info.polygons_triangulated, 1);
        // An index out of range is the sequential path's exact error.
        assert!(matches!(
            parse(&binary_with_props(&[&[0, 1, 2], &[0, 1, 5]])),
            Err(IoError::IndexOutOfRange {
                index: 5,
                vertices: 5,
                ..
            })
        ));
        assert!(matches!(
            parse(&binary_with_props(&[&[0, -1, 2]])),
            Err(IoError::IndexOutOfRange { index: -1, .. })
        ));
        // A non-finite coordinate names its vertex.
        let mut b = binary_with_props(&[&[0, 1, 2]]);
        let at = b.len() - 14 - 5 * 17 + 2 * 17 + 5;
        b[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
        assert!(matches!(
            parse(&b),
            Err(IoError::NonFinite { vertex: 2, .. })
        ));
    }

    #[test]
    fn ascii_with_extra_elements_and_properties() {
        let src = b"ply\nformat ascii 1.0\ncomment x\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty list uchar int junk\nproperty uchar red\nelement face 1\nproperty uchar flags\nproperty list uchar int vertex_index\nelement edge 1\nproperty int a\nproperty int b\nend_header\n0 0 0 2 7 7 255\n1 0 0 0 0\n1 1 0 1 5 0\n0 1 0 0 0\n9 4 0 1 2 3\n0 1\n";
        let (m, info) = parse(src).unwrap();
        assert_eq!(m.n_vertices(), 4);
        assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(info.polygons_triangulated, 1);
    }

    fn binary(big: bool, strips: &[i32]) -> Vec<u8> {
        let mut b = format!(
            "ply\nformat {} 1.0\nelement vertex 4\nproperty short x\nproperty double y\nproperty float z\nelement tristrips 1\nproperty list int int vertex_indices\nend_header\n",
            if big { "binary_big_endian" } else { "binary_little_endian" }
        )
        .into_bytes();
        for (x, y, z) in [
            (0i16, 0.0f64, 0.0f32),
            (1, 0.0, 0.0),
            (0, 1.0, 0.0),
            (1, 1.0, 0.5),
        ] {
            if big {
                b.extend(x.to_be_bytes());
                b.extend(y.to_be_bytes());
                b.extend(z.to_be_bytes());
            } else {
                b.extend(x.to_le_bytes());
                b.extend(y.to_le_bytes());
                b.extend(z.to_le_bytes());
            }
        }
        let n = strips.len() as i32;
        let push = |b: &mut Vec<u8>, v: i32| {
            if big {
                b.extend(v.to_be_bytes())
            } else {
                b.extend(v.to_le_bytes())
            }
        };
        push(&mut b, n);
        for &s in strips {
            push(&mut b, s);
        }
        b
    }

    #[test]
    fn binary_tristrips_both_endiannesses() {
        for big in [false, true] {
            let (m, info) = parse(&binary(big, &[0, 1, 2, 3, -1, 0, 0, 1, 2])).unwrap();
            assert_eq!(m.positions[3], [1.0, 1.0, 0.5]);
            // strip 0 1 2 3: (0,1,2), (2,1,3); strip 0 0 1 2: (0,0,1) skipped, (0,1,2)... flipped
            assert_eq!(m.faces, vec![[0, 1, 2], [2, 1, 3], [1, 0, 2]]);
            assert_eq!(info.triangles_from_strips, 3);
            assert_eq!(info.degenerate_strip_triangles_skipped, 1);
        }
    }

    /// A binary file of `nv` vertices (float x, y, z) and one `tristrips` record whose
    /// list has `item` entries (`int`, `uint`, `short`, `uchar`, `float`) and an
    /// `int` count, with a `uchar` property before the list.
    fn strips_file(big: bool, item: &str, nv: usize, list: &[i64]) -> Vec<u8> {
        let mut b = format!(
            "ply\nformat {} 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\nproperty float z\nelement tristrips 1\nproperty uchar flag\nproperty list int {item} vertex_indices\nend_header\n",
            if big { "binary_big_endian" } else { "binary_little_endian" }
        )
        .into_bytes();
        macro_rules! put {
            ($v:expr) => {
                if big {
                    b.extend($v.to_be_bytes())
                } else {
                    b.extend($v.to_le_bytes())
                }
            };
        }
        for v in 0..nv {
            for c in 0..3 {
                put!((v * 3 + c) as f32);
            }
        }
        b.push(7);
        put!(list.len() as i32);
        for &x in list {
            match item {
                "int" => put!(x as i32),
                "uint" => put!(x as u32),
                "short" => put!(x as i16),
                "uchar" => put!(x as u8),
                _ => put!(x as f32),
            }
        }
        b
    }

    #[test]
    fn strip_items_in_blocks_equal_the_item_by_item_read() {
        let nv = 200;
        let mut rng = crate::rng::SplitMix64::new(5);
        // Strips of 0 to 40 items with restarts, repeated vertices (joins) and a
        // restart at either end.
        let mut list = vec![-1i64];
        while list.len() < 3000 {
            for _ in 0..rng.below(41) {
                let x = if rng.below(10) == 0 {
                    *list.last().unwrap()
                } else {
                    rng.below(nv as u64) as i64
                };
                list.push(if x < 0 { 0 } else { x });
            }
            list.push(-1);
        }
        for big in [false, true] {
            for item in ["int", "uint", "short", "uchar", "float"] {
                // Unsigned items cannot hold -1: their strips are joined by repeats only.
                let list: Vec<i64> = if item == "uint" || item == "uchar" {
                    list.iter().map(|&x| x.max(0)).collect()
                } else {
                    list.clone()
                };
                let b = strips_file(big, item, nv, &list);
                let slow = read_fixed(&b, None);
                let (m, info) = slow.clone().unwrap();
                assert!(m.n_faces() > 1000 && info.degenerate_strip_triangles_skipped > 10);
                for per_task in [1, 7, 64, 1000, RECORDS_PER_TASK] {
                    assert_eq!(
                        read_fixed(&b, Some(per_task)),
                        slow,
                        "{big} {item} {per_task}"
                    );
                }
                // Two indices out of range: the first is named.
                let mut bad = list.clone();
                bad[2500] = nv as i64 + 3;
                bad[1200] = nv as i64;
                let b = strips_file(big, item, nv, &bad);
                let slow = read_fixed(&b, None);
                assert!(slow
                    .as_ref()
                    .unwrap_err()
                    .contains(&format!("face index {nv} is out of range")));
                for per_task in [1, 7, 64, 1000] {
                    assert_eq!(
                        read_fixed(&b, Some(per_task)),
                        slow,
                        "{big} {item} {per_task}"
                    );
                }
            }
        }
        // A NaN index is out of range, not vertex 0.
        let mut b = strips_file(false, "float", nv, &[0, 1, 2, 3]);
        let at = b.len() - 8;
        b[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
        assert!(read_fixed(&b, None).unwrap_err().contains("out of range"));
    }

    #[test]
    fn strip_triangles_equal_a_strip_by_strip_decoding() {
        let mut rng = crate::rng::SplitMix64::new(9);
        for _ in 0..200 {
            let list: Vec<u32> = (0..rng.below(60))
                .map(|_| match rng.below(8) {
                    0 => u32::MAX,
                    _ => rng.below(6) as u32,
                })
                .collect();
            let mut expected = Vec::new();
            let (mut made, mut skipped) = (0, 0);
            for strip in list.split(|&v| v == u32::MAX) {
                for t in 0..strip.len().saturating_sub(2) {
                    let (a, b, c) = (strip[t], strip[t + 1], strip[t + 2]);
                    if a == b || b == c || a == c {
                        skipped += 1;
                    } else {
                        expected.push(if t % 2 == 0 { [a, b, c] } else { [b, a, c] });
                        made += 1;
                    }
                }
            }
            let mut faces = Vec::new();
            let mut info = ReadInfo::new(crate::io::Format::Ply);
            strip_triangles(&list, &mut faces, &mut info);
            assert_eq!(faces, expected, "{list:?}");
            assert_eq!(info.triangles_from_strips, made);
            assert_eq!(info.degenerate_strip_triangles_skipped, skipped);
        }
    }

    #[test]
    fn hostile_and_truncated_input() {
        let full = binary(false, &[0, 1, 2, 3]);
        for cut in [full.len() - 1, full.len() - 9, 150] {
            assert!(parse(&full[..cut]).is_err(), "cut {cut}");
        }
        let huge = b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
        assert!(matches!(parse(huge), Err(IoError::Header { .. })));
        // a list claiming 2^31 items
        let mut b = binary(false, &[]);
        let k = b.len() - 4;
        b[k..].copy_from_slice(&i32::MAX.to_le_bytes());
        assert!(matches!(parse(&b), Err(IoError::Truncated { .. })));
        assert!(matches!(parse(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n3 0 1 2\n"), Err(IoError::IndexOutOfRange { line: 11, index: 1, .. })));
        assert!(matches!(parse(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 zz\n"), Err(IoError::Parse { line: 8, .. })));
        assert!(matches!(
            parse(b"ply\nformat weird 1.0\nend_header\n"),
            Err(IoError::Header { .. })
        ));
        assert!(matches!(
            parse(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"),
            Err(IoError::Header { .. })
        ));
    }
}
