//! The one median the crate's robust statistics use.

/// The middle value of `values`, the upper one of an even count (an order
/// statistic, never a mean of two, so it is always one of the values);
/// `None` when empty. Quickselect: reorders `values`, O(n).
pub fn upper_median(values: &mut [f64]) -> Option<f64> {
    let mid = values.len() / 2;
    if values.is_empty() {
        return None;
    }
    Some(*values.select_nth_unstable_by(mid, f64::total_cmp).1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_middle_value_the_upper_of_two_and_none_of_nothing() {
        assert_eq!(upper_median(&mut [3.0, -1.0, 2.0]), Some(2.0));
        assert_eq!(upper_median(&mut [4.0, 1.0, 3.0, 2.0]), Some(3.0));
        assert_eq!(upper_median(&mut [7.5]), Some(7.5));
        assert_eq!(upper_median(&mut []), None);
    }
}
