//! The expected cost of an occlusion query at one node for a given child order (equation (1)
//! of Ogaki & Derouet-Jourdan, without the constant traversal term), and the order that
//! minimises it: children by Q_i / C_i, decreasing.

/// Expected cost of visiting children in the given order, where `q[i]` is the probability that
/// child i stops the ray and `c[i]` the cost of visiting it: stopping in the k-th child costs the
/// first k children's costs; no child stopping it costs all of them.
pub fn expected_cost(q: &[f64], c: &[f64]) -> f64 {
    let mut reach = 1.0; // probability that no earlier child stopped the ray
    let mut spent = 0.0;
    let mut cost = 0.0;
    for (&qi, &ci) in q.iter().zip(c) {
        spent += ci;
        cost += spent * qi * reach;
        reach *= 1.0 - qi;
    }
    cost + spent * reach
}

/// Indices of the children in the order that minimises [`expected_cost`]: Q_i / C_i
/// decreasing (a child with C_i = 0 and Q_i > 0 first). Ties keep the order of `tie_order`'s
/// ranks (smaller first), so equal children stay in a meaningful, deterministic order.
pub fn order_by_ratio(q: &[f64], c: &[f64], tie_rank: &[usize]) -> Vec<usize> {
    let ratio = |i: usize| {
        if c[i] > 0.0 {
            q[i] / c[i]
        } else if q[i] > 0.0 {
            f64::INFINITY
        } else {
            0.0
        }
    };
    let mut idx: Vec<usize> = (0..q.len()).collect();
    idx.sort_by(|&a, &b| {
        ratio(b)
            .total_cmp(&ratio(a))
            .then(tie_rank[a].cmp(&tie_rank[b]))
    });
    idx
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cost_of_two_children_by_hand() {
        // Stop in the first with 0.5 (cost 2), else in the second with 0.5 (cost 2 + 3),
        // else both visited (cost 5): 0.5*2 + 0.25*5 + 0.25*5.
        let c = expected_cost(&[0.5, 0.5], &[2.0, 3.0]);
        assert!((c - 3.5).abs() < 1e-12, "{c}");
        // Nothing ever stops the ray: every child is visited.
        assert_eq!(expected_cost(&[0.0, 0.0, 0.0], &[1.0, 2.0, 4.0]), 7.0);
    }

    #[test]
    fn ratio_order_puts_cheap_likely_stoppers_first() {
        let q = [0.1, 0.8, 0.1];
        let c = [1.0, 4.0, 0.1];
        assert_eq!(order_by_ratio(&q, &c, &[0, 1, 2]), vec![2, 1, 0]);
    }
}
