//! Buffers written afresh for every map or scene, in the memory they already have.
//!
//! Why the memory is kept: see [`super::scratch`].

/// `values` made `len` long with every element `fill`, in the memory it has when that is
/// enough.
pub(crate) fn refill<T: Copy>(values: &mut Vec<T>, len: usize, fill: T) {
    values.clear();
    values.resize(len, fill);
}

/// `values` made `len` long for every element to be overwritten: in the memory it has when
/// that is enough, its old elements left as they are (clearing them would be a pass over it
/// for nothing); else fresh, its old elements not copied.
pub(crate) fn resize_to_overwrite<T: Copy + Default>(values: &mut Vec<T>, len: usize) {
    if values.capacity() < len {
        *values = vec![T::default(); len];
    } else {
        values.resize(len, T::default());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_buffer_long_enough_keeps_its_memory_and_a_short_one_is_made_afresh() {
        let mut values: Vec<u32> = Vec::with_capacity(100);
        values.extend(0..100);
        let memory = values.as_ptr();
        resize_to_overwrite(&mut values, 60);
        assert_eq!((values.len(), values.as_ptr()), (60, memory), "shorter: the same memory, cut");
        resize_to_overwrite(&mut values, 100);
        assert_eq!((values.len(), values.as_ptr()), (100, memory), "up to its capacity: the same memory");
        resize_to_overwrite(&mut values, 1000);
        assert_eq!(values, vec![0; 1000], "longer than its capacity: fresh zeros");
        refill(&mut values, 10, 7);
        assert_eq!(values, vec![7; 10], "refilled: every element");
    }
}
