//! Discrete distributions for importance sampling (lights by power, environment pixels).

/// A piecewise-constant 1-D distribution over `n` bins, sampled by inverting its CDF.
#[derive(Clone, Debug)]
pub struct Distribution1d {
    cdf: Vec<f32>,
    pmf: Vec<f32>,
    total: f32,
}

impl Distribution1d {
    /// Builds from non-negative weights; all-zero or non-finite weights give a uniform one.
    pub fn new(weights: &[f32]) -> Self {
        let clean: Vec<f32> = weights
            .iter()
            .map(|&w| if w.is_finite() && w > 0.0 { w } else { 0.0 })
            .collect();
        let mut total: f64 = clean.iter().map(|&w| w as f64).sum();
        let clean = if total > 0.0 {
            clean
        } else {
            total = clean.len() as f64;
            vec![1.0; clean.len()]
        };
        let mut cdf = Vec::with_capacity(clean.len());
        let mut acc = 0.0f64;
        for &w in &clean {
            acc += w as f64;
            cdf.push((acc / total) as f32);
        }
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        let pmf = clean.iter().map(|&w| (w as f64 / total) as f32).collect();
        Self {
            cdf,
            pmf,
            total: total as f32,
        }
    }

    /// Number of bins.
    pub fn len(&self) -> usize {
        self.pmf.len()
    }

    /// True when there are no bins.
    pub fn is_empty(&self) -> bool {
        self.pmf.is_empty()
    }

    /// Sum of the weights given.
    pub fn total(&self) -> f32 {
        self.total
    }

    /// Probability of bin `i`.
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf[i]
    }

    /// Picks a bin for `u` in [0,1); returns it and `u` rescaled to [0,1) within the bin.
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32) {
        let i = self
            .cdf
            .partition_point(|&c| c <= u)
            .min(self.cdf.len() - 1);
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let width = self.cdf[i] - lo;
        let rest = if width > 0.0 {
            ((u - lo) / width).clamp(0.0, 0.999_999_9)
        } else {
            0.5
        };
        (i, rest)
    }
}

/// Walker's alias table (built with Vose's method): picks bin i with probability pmf[i] in
/// constant time with one comparison, where inverting a CDF costs a binary search whose
/// branches a random `u` mispredicts. Used for the light choice, made once per shading point.
#[derive(Clone, Debug)]
pub struct AliasTable {
    /// Probability of keeping bin i once column i is chosen.
    keep: Vec<f32>,
    /// Where column i's remaining probability goes.
    alias: Vec<u32>,
}

impl AliasTable {
    /// A table for the bin probabilities of `d`.
    pub fn new(d: &Distribution1d) -> Self {
        let n = d.len();
        let scaled: Vec<f64> = (0..n).map(|i| d.pmf(i) as f64 * n as f64).collect();
        let mut keep = vec![1.0f32; n];
        let mut alias: Vec<u32> = (0..n as u32).collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) =
            (0..n).partition(|&i| scaled[i] < 1.0);
        let mut scaled = scaled;
        while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
            small.pop();
            keep[s] = scaled[s] as f32;
            alias[s] = l as u32;
            // The large bin gives away what fills column s.
            scaled[l] -= 1.0 - scaled[s];
            if scaled[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        // Whatever is left holds (up to rounding) exactly one column's worth: keep it whole.
        Self { keep, alias }
    }

    /// The bin for `u` in [0, 1).
    #[inline]
    pub fn sample(&self, u: f32) -> usize {
        let n = self.keep.len();
        let x = u * n as f32;
        let i = (x as usize).min(n - 1);
        if x - (i as f32) < self.keep[i] {
            i
        } else {
            self.alias[i] as usize
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sampling_matches_weights() {
        let d = Distribution1d::new(&[1.0, 0.0, 3.0]);
        let mut counts = [0usize; 3];
        let n = 10_000;
        for k in 0..n {
            counts[d.sample((k as f32 + 0.5) / n as f32).0] += 1;
        }
        assert_eq!(counts[1], 0);
        assert!((counts[0] as f32 / n as f32 - 0.25).abs() < 1e-3);
        assert!((d.pmf(2) - 0.75).abs() < 1e-6);
    }

    #[test]
    fn alias_table_matches_weights() {
        let w = [1.0, 0.0, 3.0, 0.5, 2.5, 1.0];
        let d = Distribution1d::new(&w);
        let a = AliasTable::new(&d);
        let mut counts = [0usize; 6];
        let n = 60_000;
        for k in 0..n {
            counts[a.sample((k as f32 + 0.5) / n as f32)] += 1;
        }
        assert_eq!(counts[1], 0, "a zero-weight bin is never chosen");
        for (i, &c) in counts.iter().enumerate() {
            let p = c as f32 / n as f32;
            assert!((p - d.pmf(i)).abs() < 1e-3, "bin {i}: {p} vs {}", d.pmf(i));
        }
    }
}
