//! Turns fuzzer bytes into pathological numbers, orders and frequency grids.
#![allow(dead_code)]

/// A reader of fuzzer bytes; past the end every read gives zero.
pub struct Bytes<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> Bytes<'a> {
    pub fn new(data: &'a [u8]) -> Self {
        Self { data, pos: 0 }
    }

    pub fn u8(&mut self) -> u8 {
        let b = self.data.get(self.pos).copied().unwrap_or(0);
        self.pos += 1;
        b
    }

    pub fn u16(&mut self) -> u16 {
        u16::from_le_bytes([self.u8(), self.u8()])
    }

    pub fn bool(&mut self) -> bool {
        self.u8() & 1 == 1
    }

    /// Special values, raw bit patterns or moderate values.
    pub fn f64(&mut self) -> f64 {
        const SPECIAL: [f64; 16] = [
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.0,
            -0.0,
            1e308,
            -1e308,
            f64::MAX,
            f64::MIN_POSITIVE,
            5e-324,
            1e-154,
            1e154,
            -1.0,
            1.0,
            0.5,
            2.0,
        ];
        match self.u8() {
            s @ 0..=31 => SPECIAL[usize::from(s % 16)],
            32..=47 => {
                let mut b = [0u8; 8];
                for x in &mut b {
                    *x = self.u8();
                }
                f64::from_le_bytes(b)
            }
            _ => f64::from(self.u16() as i16) / 1024.0,
        }
    }

    /// A model order: mostly small, sometimes huge.
    pub fn order(&mut self) -> usize {
        const BIG: [usize; 8] = [
            40,
            1000,
            1 << 40,
            usize::MAX / 8,
            usize::MAX / 8 + 1,
            usize::MAX / 2,
            usize::MAX - 1,
            usize::MAX,
        ];
        match self.u8() {
            s @ 0..=15 => BIG[usize::from(s % 8)],
            s => usize::from(s % 6),
        }
    }

    /// `n` frequencies: increasing from a positive step, then possibly spoiled (a
    /// duplicate, a swap, a bad value, or all garbage).
    pub fn grid(&mut self, n: usize) -> Vec<f64> {
        let mut w = Vec::with_capacity(n);
        let mut acc = if self.bool() { 0.0 } else { 0.1 };
        for _ in 0..n {
            w.push(acc);
            acc += 0.01 + f64::from(self.u8()) / 128.0;
        }
        let mode = self.u8();
        if n >= 2 {
            let i = usize::from(self.u8()) % (n - 1);
            match mode % 8 {
                0 => w[i + 1] = w[i],
                1 => w.swap(i, i + 1),
                2 => w[i] = self.f64(),
                3 => w.iter_mut().for_each(|x| *x = f64::from(mode) * 0.0 - 1.0),
                _ => {}
            }
        }
        w
    }

    pub fn values(&mut self, n: usize) -> Vec<f64> {
        (0..n).map(|_| self.f64()).collect()
    }
}
