//! One swept parameter: `PATH=LO:HI:COUNT`, COUNT values from LO to HI
//! inclusive.
//!
//! ```text
//! value(k) = LO + (HI − LO) · k / (COUNT − 1)    k = 0 … COUNT − 1
//! value(0) = LO and value(COUNT − 1) = HI exactly; COUNT = 1 needs LO = HI
//! ```

use super::field_path::FieldPath;
use std::str::FromStr;

/// A swept parameter (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct SweepAxis {
    /// The scene number it sets.
    pub path: FieldPath,
    /// First value.
    pub lo: f64,
    /// Last value.
    pub hi: f64,
    /// Number of values (≥ 1).
    pub count: usize,
}

impl SweepAxis {
    /// The k-th value (k < count).
    pub fn value(&self, k: usize) -> f64 {
        if k + 1 == self.count {
            return self.hi;
        }
        if k == 0 {
            return self.lo;
        }
        self.lo + (self.hi - self.lo) * k as f64 / (self.count - 1) as f64
    }
}

impl FromStr for SweepAxis {
    type Err = String;

    fn from_str(text: &str) -> Result<SweepAxis, String> {
        let bad = |why: &str| format!("--set {text}: {why} (expected PATH=LO:HI:COUNT)");
        let (path, range) = text.split_once('=').ok_or_else(|| bad("no `=`"))?;
        let path: FieldPath = path.parse()?;
        let parts: Vec<&str> = range.split(':').collect();
        let [lo, hi, count] = parts[..] else {
            return Err(bad("the range needs three parts"));
        };
        let number = |part: &str, name: &str| -> Result<f64, String> {
            part.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(&format!("{name} `{part}` is not a finite number")))
        };
        let (lo, hi) = (number(lo, "LO")?, number(hi, "HI")?);
        let count: usize = count
            .trim()
            .parse()
            .ok()
            .filter(|&c| c >= 1)
            .ok_or_else(|| bad(&format!("COUNT `{count}` is not a positive integer")))?;
        if count == 1 && lo != hi {
            return Err(bad("COUNT 1 needs LO = HI"));
        }
        Ok(SweepAxis {
            path,
            lo,
            hi,
            count,
        })
    }
}
