//! Big-endian field writer and reader for the application data layouts.

/// Writes big-endian fields into a buffer (the caller sizes the buffer for the layout).
pub struct Put<'a> {
    buf: &'a mut [u8],
    n: usize,
}

impl<'a> Put<'a> {
    /// Writing from the start of `buf`.
    pub fn new(buf: &'a mut [u8]) -> Self {
        Put { buf, n: 0 }
    }

    /// Octets written; `None` if the buffer was too small for what was put.
    pub fn finish(self) -> Option<usize> {
        (self.n <= self.buf.len()).then_some(self.n)
    }

    /// Raw octets.
    pub fn bytes(&mut self, b: &[u8]) -> &mut Self {
        if let Some(dst) = self.buf.get_mut(self.n..self.n + b.len()) {
            dst.copy_from_slice(b);
        }
        self.n += b.len();
        self
    }

    /// One octet.
    pub fn u8(&mut self, v: u8) -> &mut Self {
        self.bytes(&[v])
    }

    /// A 16-bit unsigned integer.
    pub fn u16(&mut self, v: u16) -> &mut Self {
        self.bytes(&v.to_be_bytes())
    }

    /// A 32-bit unsigned integer.
    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.bytes(&v.to_be_bytes())
    }

    /// An IEEE-754 single.
    pub fn f32(&mut self, v: f32) -> &mut Self {
        self.bytes(&v.to_be_bytes())
    }

    /// Several singles.
    pub fn f32s(&mut self, v: &[f32]) -> &mut Self {
        for x in v {
            self.f32(*x);
        }
        self
    }
}

/// Reads big-endian fields; every read past the end gives `None`.
pub struct Get<'a> {
    buf: &'a [u8],
    n: usize,
}

impl<'a> Get<'a> {
    /// Reading from the start of `buf`.
    pub fn new(buf: &'a [u8]) -> Self {
        Get { buf, n: 0 }
    }

    /// Octets not read yet.
    pub fn remaining(&self) -> usize {
        self.buf.len() - self.n
    }

    /// The next `N` octets.
    pub fn array<const N: usize>(&mut self) -> Option<[u8; N]> {
        let a = self.buf.get(self.n..self.n + N)?.try_into().ok()?;
        self.n += N;
        Some(a)
    }

    /// One octet.
    pub fn u8(&mut self) -> Option<u8> {
        self.array::<1>().map(|a| a[0])
    }

    /// A 16-bit unsigned integer.
    pub fn u16(&mut self) -> Option<u16> {
        self.array().map(u16::from_be_bytes)
    }

    /// A 32-bit unsigned integer.
    pub fn u32(&mut self) -> Option<u32> {
        self.array().map(u32::from_be_bytes)
    }

    /// An IEEE-754 single.
    pub fn f32(&mut self) -> Option<f32> {
        self.array().map(f32::from_be_bytes)
    }

    /// `N` singles.
    pub fn f32s<const N: usize>(&mut self) -> Option<[f32; N]> {
        let mut out = [0.0; N];
        for x in out.iter_mut() {
            *x = self.f32()?;
        }
        Some(out)
    }
}
