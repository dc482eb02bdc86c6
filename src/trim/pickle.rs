//! A small Python pickle writer (protocol 4) for the skeleton annotation files MMAction2 and
//! PYSKL read (`pickle.load`), with real numpy arrays in them.
//!
//! Why not a crate: `serde-pickle` writes Python's built-in values (dicts, lists, tuples, numbers,
//! strings, bytes) but no class or function reference, so a numpy array could only be a nested
//! list, and PYSKL's pose pipeline indexes `keypoint` as an array (`kp[..., 0]`, `.shape`,
//! `.astype`). An array is written as the call `numpy.array(numpy.reshape(numpy.frombuffer(
//! <bytes>, '<f4'), <shape>))` — three public numpy functions, stable across numpy 1 and 2 (no
//! `numpy.core` internals) — which yields a writable, C-ordered `float32` array on unpickling.
//! Only these opcodes are used: `PROTO`, `GLOBAL`, `REDUCE`, `MARK`, `TUPLE*`, `EMPTY_LIST`,
//! `APPENDS`, `EMPTY_DICT`, `SETITEMS`, `BININT`, `LONG1`, `BINFLOAT`, `BINUNICODE`, `BINBYTES`,
//! `BINBYTES8`, `NONE`, `NEWTRUE`, `NEWFALSE`, `STOP`; no memo, so every value is written once.

/// A Python value to pickle.
#[derive(Debug, Clone, PartialEq)]
pub enum Py {
    /// `None`.
    None,
    /// `True` / `False`.
    Bool(bool),
    /// `int`.
    Int(i64),
    /// `float`.
    Float(f64),
    /// `str`.
    Str(String),
    /// `list`.
    List(Vec<Py>),
    /// `tuple`.
    Tuple(Vec<Py>),
    /// `dict`, in this order.
    Dict(Vec<(Py, Py)>),
    /// A C-ordered `numpy.float32` array of this shape (`data.len()` = product of `shape`).
    F32Array {
        /// Its shape.
        shape: Vec<usize>,
        /// Its values, row-major.
        data: Vec<f32>,
    },
}

impl Py {
    /// A `str`.
    #[must_use]
    pub fn str(s: &str) -> Py {
        Py::Str(s.to_owned())
    }
}

/// `PROTO 4`: every pickle's first bytes.
const PROTOCOL_4: [u8; 2] = [0x80, 4];
/// `STOP`: every pickle's last byte.
const STOP: u8 = b'.';

/// `value` pickled with protocol 4 (Python 3.4+).
#[must_use]
pub fn to_bytes(value: &Py) -> Vec<u8> {
    let mut out = PROTOCOL_4.to_vec();
    write(&mut out, value);
    out.push(STOP);
    out
}

/// A pickled dict whose last value is a list, written as a stream: the dict's other entries
/// first, then the list's items one at a time, so that the list is never held whole. The bytes
/// are [`to_bytes`]'s of the whole dict.
#[derive(Debug)]
pub struct DictEndingInList<W: std::io::Write> {
    out: W,
    /// Items written so far.
    items: u64,
    /// One item's bytes, reused.
    buffer: Vec<u8>,
}

impl<W: std::io::Write> DictEndingInList<W> {
    /// Starts the pickle of the dict `entries` followed by `last_key: [...]`, into `out`.
    ///
    /// # Errors
    /// The I/O error of `out`.
    pub fn open(mut out: W, entries: &[(Py, Py)], last_key: &Py) -> std::io::Result<Self> {
        let mut head = PROTOCOL_4.to_vec();
        head.extend_from_slice(b"}(");
        for (k, v) in entries {
            write(&mut head, k);
            write(&mut head, v);
        }
        write(&mut head, last_key);
        head.push(b']');
        out.write_all(&head)?;
        Ok(DictEndingInList {
            out,
            items: 0,
            buffer: Vec::new(),
        })
    }

    /// Appends `item` to the list.
    ///
    /// # Errors
    /// The I/O error of the writer.
    pub fn push(&mut self, item: &Py) -> std::io::Result<()> {
        self.buffer.clear();
        if self.items == 0 {
            self.buffer.push(b'('); // MARK: the list's items follow
        }
        write(&mut self.buffer, item);
        self.out.write_all(&self.buffer)?;
        self.items += 1;
        Ok(())
    }

    /// Closes the list, the dict and the pickle; gives the writer back.
    ///
    /// # Errors
    /// The I/O error of the writer.
    pub fn finish(mut self) -> std::io::Result<W> {
        if self.items > 0 {
            self.out.write_all(b"e")?; // APPENDS
        }
        self.out.write_all(&[b'u', STOP])?; // SETITEMS, STOP
        Ok(self.out)
    }
}

fn write(out: &mut Vec<u8>, value: &Py) {
    match value {
        Py::None => out.push(b'N'),
        Py::Bool(b) => out.push(if *b { 0x88 } else { 0x89 }),
        Py::Int(i) => write_int(out, *i),
        Py::Float(f) => {
            out.push(b'G');
            out.extend_from_slice(&f.to_be_bytes());
        }
        Py::Str(s) => {
            out.push(b'X');
            write_len_u32(out, s.len());
            out.extend_from_slice(s.as_bytes());
        }
        Py::List(items) => {
            out.push(b']');
            if !items.is_empty() {
                out.push(b'(');
                for v in items {
                    write(out, v);
                }
                out.push(b'e');
            }
        }
        Py::Tuple(items) => write_tuple(out, items.iter()),
        Py::Dict(items) => {
            out.push(b'}');
            if !items.is_empty() {
                out.push(b'(');
                for (k, v) in items {
                    write(out, k);
                    write(out, v);
                }
                out.push(b'u');
            }
        }
        Py::F32Array { shape, data } => write_array(out, shape, data),
    }
}

fn write_tuple<'a>(out: &mut Vec<u8>, items: impl ExactSizeIterator<Item = &'a Py>) {
    if items.len() == 0 {
        out.push(b')');
        return;
    }
    out.push(b'(');
    for v in items {
        write(out, v);
    }
    out.push(b't');
}

fn write_int(out: &mut Vec<u8>, i: i64) {
    if let Ok(small) = i32::try_from(i) {
        out.push(b'J');
        out.extend_from_slice(&small.to_le_bytes());
    } else {
        out.extend_from_slice(&[0x8a, 8]);
        out.extend_from_slice(&i.to_le_bytes());
    }
}

/// A 4-byte little-endian length. Strings of 4 GiB and more are not written (none is: they are
/// names and paths).
fn write_len_u32(out: &mut Vec<u8>, len: usize) {
    let len = u32::try_from(len).unwrap_or(u32::MAX);
    out.extend_from_slice(&len.to_le_bytes());
}

fn write_global(out: &mut Vec<u8>, module: &str, name: &str) {
    out.push(b'c');
    out.extend_from_slice(module.as_bytes());
    out.push(b'\n');
    out.extend_from_slice(name.as_bytes());
    out.push(b'\n');
}

/// `numpy.array(numpy.reshape(numpy.frombuffer(bytes, '<f4'), shape))`.
fn write_array(out: &mut Vec<u8>, shape: &[usize], data: &[f32]) {
    write_global(out, "numpy", "array");
    write_global(out, "numpy", "reshape");
    write_global(out, "numpy", "frombuffer");
    let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
    if let Ok(len) = u32::try_from(bytes.len()) {
        out.push(b'B');
        out.extend_from_slice(&len.to_le_bytes());
    } else {
        out.push(0x8e);
        out.extend_from_slice(&(bytes.len() as u64).to_le_bytes());
    }
    out.extend_from_slice(&bytes);
    write(out, &Py::str("<f4"));
    out.push(0x86); // TUPLE2: (bytes, dtype)
    out.push(b'R'); // frombuffer(...)
    let dims: Vec<Py> = shape
        .iter()
        .map(|&d| Py::Int(i64::try_from(d).unwrap_or(i64::MAX)))
        .collect();
    write_tuple(out, dims.iter());
    out.push(0x86); // TUPLE2: (flat, shape)
    out.push(b'R'); // reshape(...)
    out.push(0x85); // TUPLE1: (reshaped,)
    out.push(b'R'); // array(...): a writable copy
}

#[cfg(test)]
mod tests {
    use super::{DictEndingInList, Py, to_bytes};

    #[test]
    fn a_streamed_dict_ending_in_a_list_is_the_whole_dicts_pickle() {
        let entries = vec![
            (
                Py::str("split"),
                Py::Dict(vec![(Py::str("train"), Py::List(vec![]))]),
            ),
            (Py::str("n"), Py::Int(3)),
        ];
        let item = |i: usize| {
            Py::Dict(vec![
                (Py::str("frame_dir"), Py::Str(format!("clip{i}"))),
                (
                    Py::str("keypoint"),
                    Py::F32Array {
                        shape: vec![1, i, 2],
                        data: (0..2 * i).map(|v| v as f32 * 0.5).collect(),
                    },
                ),
            ])
        };
        for n in [0, 1, 3] {
            let items: Vec<Py> = (0..n).map(item).collect();
            let mut whole = entries.clone();
            whole.push((Py::str("annotations"), Py::List(items.clone())));
            let mut s =
                DictEndingInList::open(Vec::new(), &entries, &Py::str("annotations")).unwrap();
            for i in &items {
                s.push(i).unwrap();
            }
            assert_eq!(s.finish().unwrap(), to_bytes(&Py::Dict(whole)), "{n} items");
        }
    }

    #[test]
    fn values_pickle_to_pythons_opcodes() {
        // Checked against Python 3.11: `pickle.loads` gives {'a': [1, 2.5, None], 'b': ('x', True)}.
        let v = Py::Dict(vec![
            (
                Py::str("a"),
                Py::List(vec![Py::Int(1), Py::Float(2.5), Py::None]),
            ),
            (Py::str("b"), Py::Tuple(vec![Py::str("x"), Py::Bool(true)])),
        ]);
        let mut want = vec![0x80, 4, b'}', b'('];
        want.extend_from_slice(b"X\x01\x00\x00\x00a](J\x01\x00\x00\x00G");
        want.extend_from_slice(&2.5f64.to_be_bytes());
        want.extend_from_slice(b"NeX\x01\x00\x00\x00b(X\x01\x00\x00\x00x\x88tu.");
        assert_eq!(to_bytes(&v), want);
        assert_eq!(&to_bytes(&Py::Int(1 << 40))[2..4], &[0x8a, 8]);
        assert_eq!(to_bytes(&Py::Tuple(vec![])), vec![0x80, 4, b')', b'.']);
    }

    #[test]
    fn an_array_is_a_numpy_call_with_its_bytes_and_shape() {
        let b = to_bytes(&Py::F32Array {
            shape: vec![1, 2],
            data: vec![1.0, -2.0],
        });
        let text = String::from_utf8_lossy(&b);
        assert!(text.contains("cnumpy\narray\ncnumpy\nreshape\ncnumpy\nfrombuffer\nB\x08\0\0\0"));
        let at = b
            .windows(8)
            .position(|w| w == [0, 0, 0x80, 0x3f, 0, 0, 0, 0xc0]);
        assert!(at.is_some(), "{b:?}");
        assert!(b.ends_with(b"\x86R(J\x01\x00\x00\x00J\x02\x00\x00\x00t\x86R\x85R."));
    }
}
