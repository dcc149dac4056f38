//! Fast path for DAQ buffer payloads (`{"t0_ns":..,"dt_ns":..,"value":[..]}`):
//! one pass over the borrowed bytes that appends the values straight to a
//! channel's sample vector, without a per-message `Vec<Option<f64>>`.
//!
//! It handles a strict subset of what serde_json accepts for `BufferMsg`:
//! a JSON object with exactly the keys `t0_ns`, `dt_ns` and `value` (any
//! order, no escapes, JSON whitespace anywhere), unsigned integer times and
//! an array of numbers and `null`s. Anything else (unknown or repeated keys,
//! malformed numbers, out-of-range values, trailing bytes, ...) returns
//! `None` with the output vector unchanged, and the caller decodes the
//! payload with serde_json as before; so acceptance and error messages stay
//! serde_json's.
//!
//! Numbers are correctly rounded, like serde_json's with `float_roundtrip`:
//! exactly representable mantissa and power of ten (Clinger's fast path, one
//! rounding) or else the standard library's correctly rounding
//! `f64::from_str` on the token. Correct rounding is unique, so the values
//! are bit-identical to serde_json's. The short numbers a DAQ writes (at
//! most 7 integer and 7 fraction digits) have their digits read eight bytes
//! at a time (`number_short`), with no branch per digit.

/// Powers of ten exactly representable in an f64.
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// Largest integer below which every integer is an exact f64.
const EXACT_INT: u64 = 1 << 53;

/// Parses a DAQ buffer payload: appends `value[i] * scale` (NaN for `null`)
/// to `out` and returns `(t0_ns, dt_ns, values appended)`. `None` when the
/// payload is outside the handled subset (see the module doc); `out` is then
/// as on entry.
pub(super) fn parse_buffer(data: &[u8], scale: f64, out: &mut Vec<f64>) -> Option<(u64, u64)> {
    let start = out.len();
    let r = Parser { b: data, i: 0 }.buffer(scale, out);
    if r.is_none() {
        out.truncate(start);
    }
    r
}

struct Parser<'a> {
    b: &'a [u8],
    i: usize,
}

impl Parser<'_> {
    #[inline(always)]
    fn peek(&self) -> Option<u8> {
        self.b.get(self.i).copied()
    }

    #[inline(always)]
    fn ws(&mut self) {
        while let Some(b' ' | b'\n' | b'\t' | b'\r') = self.peek() {
            self.i += 1;
        }
    }

    #[inline(always)]
    fn eat(&mut self, c: u8) -> Option<()> {
        if self.peek() == Some(c) {
            self.i += 1;
            Some(())
        } else {
            None
        }
    }

    fn buffer(mut self, scale: f64, out: &mut Vec<f64>) -> Option<(u64, u64)> {
        let (mut t0, mut dt, mut seen_value) = (None, None, false);
        self.ws();
        self.eat(b'{')?;
        loop {
            self.ws();
            self.eat(b'"')?;
            // The key runs to the next quote: one of the three, or the
            // payload is left to serde_json.
            let rest = &self.b[self.i..];
            let key: &[u8] = [b"t0_ns".as_slice(), b"dt_ns", b"value"]
                .into_iter()
                .find(|k| rest.get(k.len()) == Some(&b'"') && rest.starts_with(k))?;
            self.i += key.len() + 1;
            self.ws();
            self.eat(b':')?;
            self.ws();
            match key {
                b"t0_ns" if t0.is_none() => t0 = Some(self.uint()?),
                b"dt_ns" if dt.is_none() => dt = Some(self.uint()?),
                b"value" if !seen_value => {
                    self.values(scale, out)?;
                    seen_value = true;
                }
                _ => return None, // unknown, escaped or repeated key
            }
            self.ws();
            match self.peek()? {
                b',' => self.i += 1,
                b'}' => {
                    self.i += 1;
                    break;
                }
                _ => return None,
            }
        }
        self.ws();
        if self.i != self.b.len() || !seen_value {
            return None;
        }
        Some((t0?, dt?))
    }

    /// A JSON unsigned integer that fits a u64. Up to 19 digits (below
    /// 10^19 < 2^64: no overflow) are read eight bytes at a time; longer
    /// runs digit by digit with overflow checks.
    fn uint(&mut self) -> Option<u64> {
        let first = self.peek()?;
        if !first.is_ascii_digit() {
            return None;
        }
        let start = self.i;
        let mut v = 0;
        if first == b'0' {
            self.i += 1;
            if matches!(self.peek(), Some(b'0'..=b'9')) {
                return None;
            }
        } else {
            let mut n = 0;
            loop {
                let x = digit_values(load8(self.b, start + n));
                let k = digit_run(x);
                if k == 0 {
                    break;
                }
                if n + k > 19 {
                    return self.uint_long(start);
                }
                // v < 10^n: v * 10^k + (k digits) < 10^(n+k) <= 10^19 < 2^64.
                v = v * POW10_INT9[k] + digits_value(x, k);
                n += k;
                if k < 8 {
                    break;
                }
            }
            self.i = start + n;
        }
        if matches!(self.peek(), Some(b'.' | b'e' | b'E')) {
            return None; // a float where serde wants an integer
        }
        Some(v)
    }

    /// [`Parser::uint`] for a run of 20 or more digits (not 0) at `start`.
    #[cold]
    #[inline(never)]
    fn uint_long(&mut self, start: usize) -> Option<u64> {
        self.i = start;
        let mut v: u64 = 0;
        while let Some(c @ b'0'..=b'9') = self.peek() {
            v = v.checked_mul(10)?.checked_add(u64::from(c - b'0'))?;
            self.i += 1;
        }
        if matches!(self.peek(), Some(b'.' | b'e' | b'E')) {
            return None; // a float where serde wants an integer
        }
        Some(v)
    }

    /// The `value` array.
    fn values(&mut self, scale: f64, out: &mut Vec<f64>) -> Option<()> {
        // x * 1.0 == x for every finite x: unscaled values skip the multiply.
        self.i = if scale == 1.0 {
            values::<false>(self.b, self.i, scale, out)?
        } else {
            values::<true>(self.b, self.i, scale, out)?
        };
        Some(())
    }
}

/// Whether `c` is JSON whitespace.
#[inline(always)]
fn is_ws(c: u8) -> bool {
    matches!(c, b' ' | b'\n' | b'\t' | b'\r')
}

/// The `value` array starting at `b[i]`: appends its values times `scale`
/// (NaN for `null`) to `out` and returns the index just past it. A
/// function of its own, on locals, for a tight loop; `SCALED`: whether to
/// multiply by `scale`.
#[inline(never)]
fn values<const SCALED: bool>(
    b: &[u8],
    mut i: usize,
    scale: f64,
    out: &mut Vec<f64>,
) -> Option<usize> {
    let skip_ws = |mut i: usize| {
        while b.get(i).is_some_and(|&c| is_ws(c)) {
            i += 1;
        }
        i
    };
    if b.get(i) != Some(&b'[') {
        return None;
    }
    i = skip_ws(i + 1);
    if b.get(i) == Some(&b']') {
        return Some(i + 1);
    }
    loop {
        let c = *b.get(i)?;
        // The DAQ's usual number, -?D.F{1,7} right before the separator,
        // from one 16-byte window (not near the payload's end): the same
        // mantissa and division as `number_short`'s, and the separator
        // read from the fraction's word.
        let negative = c == b'-';
        let j = i + usize::from(negative);
        if let Some(w) = b.get(j..).and_then(<[u8]>::first_chunk::<16>) {
            let d0 = w[0].wrapping_sub(b'0');
            let f = digit_values(u64::from_le_bytes([
                w[2], w[3], w[4], w[5], w[6], w[7], w[8], w[9],
            ]));
            let n = digit_run(f);
            if d0 <= 9 && w[1] == b'.' && (1..8).contains(&n) {
                // Then the separator, or a negative two-digit exponent and
                // the separator (`9.6e-05`); the power of ten 10^(n + e) is
                // within Clinger's range (n + e <= 22 is checked).
                let (e, end) = match w[2 + n] {
                    sep @ (b',' | b']') => (0, (sep, 3 + n)),
                    b'e' if w[3 + n] == b'-' => {
                        let (e1, e2) = (w[4 + n].wrapping_sub(b'0'), w[5 + n].wrapping_sub(b'0'));
                        let e = usize::from(e1) * 10 + usize::from(e2);
                        if e1 <= 9 && e2 <= 9 && n + e <= 22 {
                            (e, (w[6 + n], 7 + n))
                        } else {
                            (0, (0, 0))
                        }
                    }
                    _ => (0, (0, 0)),
                };
                let (sep, len) = end;
                if sep == b',' || sep == b']' {
                    // At most 8 digits: exact in an f64.
                    let m = u64::from(d0) * POW10_INT[n] + digits_value(f, n);
                    let x = m as i64 as f64 / POW10[n + e];
                    let x = f64::from_bits(x.to_bits() | u64::from(negative) << 63);
                    out.push(if SCALED { x * scale } else { x });
                    i = j + len;
                    if sep == b']' {
                        return Some(i);
                    }
                    continue;
                }
            }
        }
        let x = if c == b'n' {
            if b.get(i..i + 4)? != b"null" {
                return None;
            }
            i += 4;
            f64::NAN
        } else if is_ws(c) {
            i = skip_ws(i);
            continue;
        } else {
            let (x, end) = match number_short(b, i) {
                (_, LONG_WAY) => number_long(b, i)?,
                short => short,
            };
            i = end;
            if SCALED {
                x * scale
            } else {
                x
            }
        };
        out.push(x);
        // The DAQ writes no whitespace: the separator comes first.
        let mut c = *b.get(i)?;
        if is_ws(c) {
            i = skip_ws(i);
            c = *b.get(i)?;
        }
        i += 1;
        match c {
            b',' => {}
            b']' => return Some(i),
            _ => return None,
        }
    }
}

/// The 8 bytes at `b[i..]` as a little-endian word (first byte lowest),
/// zero-padded past the end of `b`.
#[inline(always)]
fn load8(b: &[u8], i: usize) -> u64 {
    match b.get(i..).and_then(<[u8]>::first_chunk::<8>) {
        Some(w) => u64::from_le_bytes(*w),
        None => load_tail(b, i),
    }
}

/// [`load8`] within the last 8 bytes of `b`.
#[cold]
#[inline(never)]
fn load_tail(b: &[u8], i: usize) -> u64 {
    let mut w = [0u8; 8];
    for (d, s) in w.iter_mut().zip(b.get(i..).unwrap_or(&[])) {
        *d = *s;
    }
    u64::from_le_bytes(w)
}

/// `w` with every ASCII digit byte turned into its value (0 to 9); other
/// bytes become values above 9.
#[inline(always)]
fn digit_values(w: u64) -> u64 {
    w ^ 0x3030_3030_3030_3030
}

/// How many bytes of `x` (from [`digit_values`], first byte lowest) are
/// digits (at most 9) before the first that is not (8 if all are).
#[inline(always)]
fn digit_run(x: u64) -> usize {
    // The top bit of each byte above 9: either the byte itself has it, or
    // adding 0x76 sets it. A carry out of a byte (one above 0x89, itself
    // flagged) only reaches the bytes after it, which do not count.
    let flags = (x.wrapping_add(0x7676_7676_7676_7676) | x) & 0x8080_8080_8080_8080;
    (flags.trailing_zeros() / 8) as usize
}

/// The integer whose decimal digits are the first `n` (1 to 8) bytes of
/// `x`, digit values (first byte lowest, most significant).
#[inline(always)]
fn digits_value(x: u64, n: usize) -> u64 {
    // The first `n` digits moved to the top: the bytes below them are
    // zeros, i.e. leading zeros (the bytes after them drop out).
    let v = x << (8 * (8 - n));
    // Pairs, then the four pairs (the classic SWAR eight-digit parse).
    let v = v.wrapping_mul(10).wrapping_add(v >> 8);
    let pairs = 0x0000_00FF_0000_00FF;
    let v = ((v & pairs).wrapping_mul(100 + (1_000_000 << 32)))
        .wrapping_add(((v >> 16) & pairs).wrapping_mul(1 + (10_000 << 32)));
    v >> 32
}

/// Powers of ten as integers, up to 10^7 (a fraction of at most 7 digits).
const POW10_INT: [u64; 8] = [1, 10, 100, 1_000, 10_000, 100_000, 1_000_000, 10_000_000];

/// Powers of ten as integers, up to 10^8 (a word of digits).
const POW10_INT9: [u64; 9] = [
    1,
    10,
    100,
    1_000,
    10_000,
    100_000,
    1_000_000,
    10_000_000,
    100_000_000,
];

/// The JSON number starting at `b[start]`, as [`number`] returns it, by a
/// quicker route for the short numbers a DAQ writes: at most 7 integer and
/// 7 fraction digits, an exponent of at most 2 digits, with a power of ten
/// in Clinger's range. Those are read a word at a time and computed as
/// [`number`] computes them (the same integer mantissa and the same one
/// correctly rounded operation); anything else returns [`LONG_WAY`] as the
/// end, for the caller to call [`number`] (which keeps this result in
/// registers).
#[inline(always)]
fn number_short(b: &[u8], start: usize) -> (f64, usize) {
    let negative = b.get(start) == Some(&b'-');
    let mut i = start + usize::from(negative);
    let first = b.get(i).map_or(10, |c| c.wrapping_sub(b'0'));
    let mut mantissa;
    if first <= 9 && b.get(i + 1) == Some(&b'.') {
        // One integer digit (the usual case for values in SI units).
        mantissa = u64::from(first);
        i += 1;
    } else {
        let x = digit_values(load8(b, i));
        let n = digit_run(x);
        // No digit, 8 or more, or a leading zero (invalid JSON): the long way.
        if n == 0 || n == 8 || (n > 1 && first == 0) {
            return (0.0, LONG_WAY);
        }
        mantissa = digits_value(x, n);
        i += n;
    }
    let mut exp10: i64 = 0;
    if b.get(i) == Some(&b'.') {
        let x = digit_values(load8(b, i + 1));
        let n = digit_run(x);
        if n == 0 || n == 8 {
            return (0.0, LONG_WAY);
        }
        // At most 7 + 7 digits: below 10^14 < 2^53, exact.
        mantissa = mantissa * POW10_INT[n] + digits_value(x, n);
        exp10 = -(n as i64);
        i += 1 + n;
    }
    if b.get(i).is_some_and(|&c| c | 0x20 == b'e') {
        i += 1;
        let exp_negative = b.get(i) == Some(&b'-');
        if exp_negative || b.get(i) == Some(&b'+') {
            i += 1;
        }
        let x = digit_values(load8(b, i));
        let n = digit_run(x);
        if n == 0 || n > 2 {
            return (0.0, LONG_WAY);
        }
        let e = digits_value(x, n) as i64;
        exp10 += if exp_negative { -e } else { e };
        i += n;
    }
    if !(-22..=22).contains(&exp10) {
        return (0.0, LONG_WAY);
    }
    // Below 2^53: the same value through i64 (a single instruction).
    let m = mantissa as i64 as f64;
    let v = if exp10 < 0 {
        m / POW10[(-exp10) as usize]
    } else {
        m * POW10[exp10 as usize]
    };
    // The sign bit set for a negative number (v >= +0): -v, without a branch.
    let v = f64::from_bits(v.to_bits() | u64::from(negative) << 63);
    (v, i)
}

/// The end [`number_short`] returns for a number it leaves to [`number`].
const LONG_WAY: usize = usize::MAX;

/// [`number`], out of the way of the loop that rarely needs it.
#[cold]
#[inline(never)]
fn number_long(b: &[u8], start: usize) -> Option<(f64, usize)> {
    number(b, start)
}

/// Advances `i` over ASCII digits, accumulating them into `acc` (wrapping;
/// exact while at most 19 digits are taken). Returns how many it took.
#[inline(always)]
fn digits(b: &[u8], i: &mut usize, acc: &mut u64) -> usize {
    let from = *i;
    let (mut j, mut a) = (*i, *acc);
    while j < b.len() {
        let d = b[j].wrapping_sub(b'0');
        if d > 9 {
            break;
        }
        a = a.wrapping_mul(10).wrapping_add(u64::from(d));
        j += 1;
    }
    *i = j;
    *acc = a;
    j - from
}

/// The JSON number starting at `b[start]` as a finite, correctly rounded
/// f64, and the index just past it; `None` if it is not a JSON number, not
/// finite, or has a huge exponent (left to serde_json).
#[inline(never)]
fn number(b: &[u8], start: usize) -> Option<(f64, usize)> {
    let mut i = start;
    let negative = b.get(i) == Some(&b'-');
    if negative {
        i += 1;
    }
    // Digits of the integer and fraction parts as one integer (exact while
    // there are at most 19 of them; leading zeros add nothing).
    let mut mantissa: u64 = 0;
    // Integer part: 0 or [1-9][0-9]*.
    let int_start = i;
    let mut n_digits = digits(b, &mut i, &mut mantissa);
    if n_digits == 0 || (b[int_start] == b'0' && n_digits > 1) {
        return None;
    }
    let mut exp10: i64 = 0;
    if b.get(i) == Some(&b'.') {
        i += 1;
        let n = digits(b, &mut i, &mut mantissa);
        if n == 0 {
            return None;
        }
        n_digits += n;
        exp10 = -(n as i64);
    }
    if let Some(b'e' | b'E') = b.get(i) {
        i += 1;
        let exp_negative = match b.get(i) {
            Some(b'-') => {
                i += 1;
                true
            }
            Some(b'+') => {
                i += 1;
                false
            }
            _ => false,
        };
        let mut e: u64 = 0;
        let n = digits(b, &mut i, &mut e);
        if n == 0 || n > 4 {
            return None; // no exponent digits, or a huge exponent
        }
        exp10 += if exp_negative { -(e as i64) } else { e as i64 };
    }
    if n_digits <= 19 && mantissa <= EXACT_INT && (-22..=22).contains(&exp10) {
        // Both operands exact: one correctly rounded operation (and a
        // finite result: at most 2^53 * 1e22).
        let m = mantissa as f64;
        let v = if exp10 < 0 {
            m / POW10[(-exp10) as usize]
        } else {
            m * POW10[exp10 as usize]
        };
        return Some((if negative { -v } else { v }, i));
    }
    // The token is a valid JSON number, hence valid for from_str.
    let token = std::str::from_utf8(&b[start..i]).ok()?;
    let v = token.parse::<f64>().ok()?;
    v.is_finite().then_some((v, i))
}

#[cfg(test)]
mod tests {
    use super::parse_buffer;
    use proptest::prelude::*;
    use serde::Deserialize;

    #[derive(Deserialize)]
    struct BufferMsg {
        t0_ns: u64,
        dt_ns: u64,
        value: Vec<Option<f64>>,
    }

    /// The fast path agrees with serde_json: where it accepts, serde_json
    /// accepts with bit-identical values; where serde_json refuses, it
    /// refuses (and leaves the output as it was).
    fn agrees(text: &str) -> bool {
        let mut out = vec![7.0];
        let fast = parse_buffer(text.as_bytes(), 1.0, &mut out);
        let slow: Result<BufferMsg, _> = serde_json::from_str(text);
        match (fast, slow) {
            (Some((t0, dt)), Ok(m)) => {
                let want: Vec<u64> = std::iter::once(7.0f64.to_bits())
                    .chain(m.value.iter().map(|v| v.map_or(f64::NAN, |x| x).to_bits()))
                    .collect();
                let got: Vec<u64> = out.iter().map(|v| v.to_bits()).collect();
                assert_eq!((t0, dt), (m.t0_ns, m.dt_ns), "{text}");
                assert_eq!(got, want, "{text}");
                true
            }
            (Some(_), Err(e)) => panic!("fast path accepted what serde_json refuses ({e}): {text}"),
            (None, _) => {
                assert_eq!(out, vec![7.0], "{text}");
                false
            }
        }
    }

    fn buffer(values: &[String]) -> String {
        format!(
            r#"{{"t0_ns":1700000000123456789,"dt_ns":2000000,"value":[{}]}}"#,
            values.join(",")
        )
    }

    #[test]
    fn canonical_payloads_take_the_fast_path() {
        let cases = [
            r#"{"t0_ns":1,"dt_ns":2,"value":[]}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[null,1,-0,-0.0,0.5,-9.6e-05,1E+3]}"#,
            " {\"value\" : [ 1 , null ] ,\n\"dt_ns\":0,\t\"t0_ns\":18446744073709551615}\r\n",
            r#"{"t0_ns":0,"dt_ns":1,"value":[0.1,0.00013,123456789012345678901234,1e-320,4.9e-324,1.7976931348623157e308]}"#,
            r#"{"t0_ns":0,"dt_ns":1,"value":[9007199254740993,9007199254740992.5,0.30000000000000004]}"#,
            // Around the limits of the word-at-a-time route (7 and 8 digits,
            // 2- and 3-digit exponents, Clinger's range), and numbers in the
            // last 8 bytes of the payload.
            r#"{"t0_ns":0,"dt_ns":1,"value":[1234567.1234567,-1234567.1234567,12345678.5,0.12345678,1e22,1e23,1.5e-22,9e-23,1.25e+07,1E-7,12.5e0,1e007,7,-0]}"#,
            r#"{"t0_ns":0,"dt_ns":1,"value":[-9.6e-05,0.0024825,-0.000128,4.04]}"#,
            // The 16-byte window: exponents at Clinger's edge, 7 and 8
            // fraction digits, E and e+, values in the last 16 bytes.
            r#"{"t0_ns":0,"dt_ns":1,"value":[9.6e-05,-1.3e-05,1.5e-21,1.5e-22,1.2345678e-05,1.12345678e-05,1.5e+05,1.5E-05,1.5e-5,9.9e-99,0.1e-00,-0.0e-01,1.5e-05,2.5e-07]}"#,
            r#"{"value":[null,-9.6e-5],"t0_ns":0,"dt_ns":1}"#,
            r#"{"t0_ns":0,"dt_ns":1,"value":[-9.6e-5]}"#,
            r#"{"t0_ns":0,"dt_ns":1,"value":[3]}"#,
        ];
        for c in cases {
            assert!(agrees(c), "{c}");
        }
    }

    #[test]
    fn everything_else_is_left_to_serde_json() {
        let cases = [
            "",
            "[1,2,[3]]",
            r#"{"t0_ns":1,"dt_ns":2}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[1],"extra":3}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[1],"value":[2]}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[1,]}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[1],}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[1]} x"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[01]}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[1.]}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[.5]}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[+1]}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[1e]}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[1e+-5]}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[-.5]}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[1.e5]}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[01.5]}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[1e5.5]}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[0.5e]}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[-]}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[1.5"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[1.5e-0"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[1e999]}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[-1e99999]}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[NaN]}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[nul]}"#,
            r#"{"t0_ns":1,"dt_ns":2,"value":[1"#,
            r#"{"t0_ns":1.0,"dt_ns":2,"value":[1]}"#,
            r#"{"t0_ns":-1,"dt_ns":2,"value":[1]}"#,
            r#"{"t0_ns":18446744073709551616,"dt_ns":2,"value":[1]}"#,
            r#"{"t0\u005fns":1,"dt_ns":2,"value":[1]}"#,
        ];
        for c in cases {
            assert!(!agrees(c), "{c}");
        }
    }

    fn number() -> impl Strategy<Value = String> {
        prop_oneof![
            any::<f64>()
                .prop_filter("finite", |x| x.is_finite())
                .prop_map(|x| format!("{x}")),
            any::<f64>()
                .prop_filter("finite", |x| x.is_finite())
                .prop_map(|x| format!("{x:e}")),
            (-1e-2f64..1e-2, 0usize..20).prop_map(|(x, p)| format!("{x:.p$}")),
            (-1e-3f64..1e-3).prop_map(|x| format!("{x:.2e}")),
            "-?(0|[1-9][0-9]{0,25})(\\.[0-9]{1,25})?([eE][-+]?[0-9]{1,3})?",
            "-?[0-9]{0,3}\\.?[0-9]{0,3}[eE]?[-+]?[0-9]{0,2}",
            // Around the word-at-a-time route's limits (7/8 digits, 2/3-digit exponents).
            "-?(0|[1-9][0-9]{0,8})(\\.[0-9]{1,9})?([eE][-+]?[0-9]{1,3})?",
            // The DAQ's (Python's) form of small values.
            "-?[0-9]\\.[0-9]{1,9}e[-+][0-9]{2}",
            Just("null".to_string()),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4000))]
        #[test]
        fn agrees_with_serde_json(values in proptest::collection::vec(number(), 0..12)) {
            agrees(&buffer(&values));
        }

        #[test]
        fn times_agree_with_serde_json(
            t0 in "[0-9]{1,24}|[1-9][0-9]{17,20}|1844674407370955161[0-9]",
            dt in any::<u64>(),
            tail in "|\\.0|e1|0|[ ,]",
        ) {
            agrees(&format!(r#"{{"t0_ns":{t0}{tail},"dt_ns":{dt},"value":[1.5]}}"#));
        }
    }
}
