//! The references between the budgets of a set: for each row, the budget it refers to, and
//! the order that evaluates every budget after those it refers to.

/// For each budget, for each row, the index of the budget the row refers to (`from`), if any.
pub(crate) type References = Vec<Vec<Option<usize>>>;

/// The budgets reachable from `roots` (in that order), each once, every budget after the budgets
/// it refers to (depth-first post-order, rows in order, without recursion). `refs` must be
/// acyclic ([`BudgetSet::references`]).
pub(crate) fn postorder(refs: &References, roots: impl Iterator<Item = usize>) -> Vec<usize> {
    let mut done = vec![false; refs.len()];
    let mut out = Vec::with_capacity(refs.len());
    let mut path: Vec<(usize, usize)> = Vec::new();
    for root in roots {
        if done[root] {
            continue;
        }
        done[root] = true;
        path.push((root, 0));
        while let Some(top) = path.last_mut() {
            let (b, row) = *top;
            if row == refs[b].len() {
                out.push(b);
                path.pop();
                continue;
            }
            top.1 += 1;
            if let Some(sub) = refs[b][row]
                && !done[sub]
            {
                done[sub] = true;
                path.push((sub, 0));
            }
        }
    }
    out
}
