//! Budgets that share nested budgets: the exact combined uncertainty when two rows of a budget
//! depend on the same budget, directly or through others.
//!
//! A budget is one quantity however many rows refer to it. When two rows of budget b depend on a
//! common budget d they are correlated through d, and the two-stage evaluation (each row with its
//! budget's u_c, the rows independent) would be wrong: two rows referring to d with c = 1 each give
//! u = 2·u(d), not √2·u(d). For such a budget u_c comes from its leaf inputs,
//!
//! ```text
//! u_c² = Σ_l (g_l u_l)² + 2 Σ_{listed pairs} g_l g_m u_l u_m r_lm
//! ```
//!
//! where g_l is leaf l's coefficient summed over every path of references (each path the product
//! of its sensitivity coefficients): the model that Monte Carlo draws. ν_eff is then
//! Welch–Satterthwaite over the budget's rows, an approximation as with any correlation. Budgets
//! whose rows share nothing keep the two-stage evaluation unchanged (Table 3 of Hsieh et al.,
//! 2022, and JCGM 100 H.1 included).
//!
//! The work is linear in the number of budgets when no budget is referred to twice (the usual
//! case: nothing is done). Otherwise it is bounded by [`MAX_SHARED_ENTRIES`].

use super::Budget;
use super::graph::References;
use crate::limits::MAX_SHARED_ENTRIES;
use crate::{UncertaintyError, short};

/// For each budget in `order` (every budget after those it refers to), the exact combined
/// standard uncertainty when two of its rows depend on a common budget; `None` for the others.
pub(crate) fn shared_u_c(
    budgets: &[Budget],
    refs: &References,
    order: &[usize],
) -> Result<Vec<Option<f64>>, UncertaintyError> {
    let nb = budgets.len();
    let mut out = vec![None; nb];
    // Nothing is shared unless some budget is referred to more than once.
    let mut referred = vec![0u32; nb];
    for &b in order {
        for s in refs[b].iter().flatten() {
            referred[*s] = referred[*s].saturating_add(1);
        }
    }
    if referred.iter().all(|&n| n <= 1) {
        return Ok(out);
    }
    // Closure of each budget (itself and every budget it depends on) as a bit set, and whether
    // two of its rows' closures overlap.
    let words = nb.div_ceil(64);
    let mut closure = vec![0u64; nb * words];
    let mut shares = vec![false; nb];
    let mut union = vec![0u64; words];
    for &b in order {
        union.fill(0);
        for s in refs[b].iter().flatten() {
            let cs = &closure[s * words..(s + 1) * words];
            if !shares[b] && union.iter().zip(cs).any(|(u, c)| u & c != 0) {
                shares[b] = true;
            }
            union.iter_mut().zip(cs).for_each(|(u, c)| *u |= c);
        }
        union[b / 64] |= 1 << (b % 64);
        closure[b * words..(b + 1) * words].copy_from_slice(&union);
    }
    if !shares.iter().any(|&s| s) {
        return Ok(out);
    }
    // Budgets whose leaf coefficients are needed: the closures of the sharing ones.
    let mut needed = vec![0u64; words];
    for b in (0..nb).filter(|&b| shares[b]) {
        needed
            .iter_mut()
            .zip(&closure[b * words..(b + 1) * words])
            .for_each(|(n, c)| *n |= c);
    }
    let is_needed = |b: usize| needed[b / 64] & (1 << (b % 64)) != 0;
    // Leaf ids: (budget, row) → offset[budget] + row.
    let mut offset = vec![0usize; nb];
    let mut total = 0usize;
    for (b, o) in offset.iter_mut().enumerate() {
        *o = total;
        total += budgets[b].contributions.len();
    }
    // Leaf coefficient vectors g, sorted by leaf id, in post-order, and the correlations.
    let mut g: Vec<Vec<(usize, f64)>> = vec![Vec::new(); nb];
    let mut cors: Vec<Vec<(usize, usize, f64)>> = vec![Vec::new(); nb];
    let mut entries = 0usize;
    let too_large = |b: usize, entries: usize| UncertaintyError::TooLarge {
        budget: Some(budgets[b].name.clone()),
        what: format!(
            "budget '{}': the leaf coefficients and correlations of budgets referred to more than once",
            short(&budgets[b].name)
        ),
        found: entries as u64,
        limit: MAX_SHARED_ENTRIES as u64,
        hint: "; refer to each budget once, or use fewer rows".into(),
    };
    for &b in order.iter().filter(|&&b| is_needed(b)) {
        let budget = &budgets[b];
        let mut v: Vec<(usize, f64)> = Vec::new();
        for (r, (c, sub)) in budget.contributions.iter().zip(&refs[b]).enumerate() {
            match sub {
                Some(s) => v.extend(g[*s].iter().map(|&(l, x)| (l, c.sensitivity * x))),
                None => v.push((offset[b] + r, c.sensitivity)),
            }
        }
        v.sort_by_key(|&(l, _)| l);
        v.dedup_by(|later, kept| {
            if later.0 == kept.0 {
                kept.1 += later.1;
                true
            } else {
                false
            }
        });
        entries += v.len();
        if entries > MAX_SHARED_ENTRIES {
            return Err(too_large(b, entries));
        }
        // A correlation on a nested row cannot be carried down to the leaves.
        let c = budget.correlation_indices()?;
        if let Some(&(i, j, _)) = c
            .iter()
            .find(|&&(i, j, _)| refs[b][i].is_some() || refs[b][j].is_some())
        {
            return Err(UncertaintyError::CorrelatedNestedBudget {
                budget: budget.name.clone(),
                a: budget.contributions[i].name.clone(),
                b: budget.contributions[j].name.clone(),
            });
        }
        g[b] = v;
        cors[b] = c;
    }
    // Leaf u of each leaf id.
    let leaf_u = |l: usize| {
        let b = offset.partition_point(|&o| o <= l) - 1;
        budgets[b].contributions[l - offset[b]].u
    };
    for b in (0..nb).filter(|&b| shares[b]) {
        let gb = &g[b];
        let coef = |l: usize| {
            gb.binary_search_by_key(&l, |&(x, _)| x)
                .map_or(0.0, |k| gb[k].1)
        };
        let scale = gb
            .iter()
            .map(|&(l, x)| (x * leaf_u(l)).abs())
            .fold(0.0f64, f64::max);
        let s = if scale > 0.0 && scale.is_finite() {
            scale
        } else {
            1.0
        };
        let mut var: f64 = gb.iter().map(|&(l, x)| (x * leaf_u(l) / s).powi(2)).sum();
        for d in members(&closure[b * words..(b + 1) * words]) {
            entries += cors[d].len();
            if entries > MAX_SHARED_ENTRIES {
                return Err(too_large(b, entries));
            }
            for &(i, j, r) in &cors[d] {
                let (li, lj) = (offset[d] + i, offset[d] + j);
                var += 2.0 * (coef(li) * leaf_u(li) / s) * (coef(lj) * leaf_u(lj) / s) * r;
            }
        }
        let u_c = s * var.max(0.0).sqrt();
        if !u_c.is_finite() {
            return Err(UncertaintyError::NonFinite {
                budget: budgets[b].name.clone(),
                contribution: None,
                quantity: "u_c = √(gᵀ·C·g) over the leaf inputs".into(),
            });
        }
        out[b] = Some(u_c);
    }
    Ok(out)
}

/// The members of a bit set, ascending.
fn members(bits: &[u64]) -> impl Iterator<Item = usize> + '_ {
    bits.iter().enumerate().flat_map(|(w, &word)| {
        let mut x = word;
        std::iter::from_fn(move || {
            if x == 0 {
                return None;
            }
            let t = x.trailing_zeros() as usize;
            x &= x - 1;
            Some(w * 64 + t)
        })
    })
}
