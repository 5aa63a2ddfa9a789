//! A fixed-capacity list whose decoding reports overflow instead of failing opaquely.
//!
//! `heapless::Vec`'s own `Deserialize` turns "too many elements" into a generic serde error, which
//! postcard cannot tell apart from any other malformed input. [`BoundedVec`] keeps the first `N`
//! elements, counts the rest, and lets model validation report
//! [`ModelError::CapacityExceeded`](crate::model_error::ModelError::CapacityExceeded) with the real length.
//! On the wire it is an ordinary postcard sequence (varint length, then the elements).

use core::fmt;
use core::marker::PhantomData;
use core::ops::Deref;

use serde::de::{SeqAccess, Visitor};
use serde::ser::SerializeSeq;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// Up to `N` elements of `T`, no allocation. Derefs to `[T]`.
#[derive(Clone, Debug, PartialEq)]
pub struct BoundedVec<T, const N: usize> {
    items: heapless::Vec<T, N>,
    /// Elements seen while decoding beyond the capacity (dropped).
    overflow: usize,
}

impl<T, const N: usize> Default for BoundedVec<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T, const N: usize> BoundedVec<T, N> {
    /// An empty list.
    pub const fn new() -> Self {
        Self {
            items: heapless::Vec::new(),
            overflow: 0,
        }
    }

    /// Appends `item`, handing it back when the list is full.
    pub fn push(&mut self, item: T) -> Result<(), T> {
        self.items.push(item)
    }

    /// The stored elements.
    pub fn as_slice(&self) -> &[T] {
        &self.items
    }

    /// The length the list had on the wire (stored elements plus dropped overflow).
    pub fn declared_len(&self) -> usize {
        self.items.len().saturating_add(self.overflow)
    }

    /// True when decoding saw more than `N` elements.
    pub fn overflowed(&self) -> bool {
        self.overflow > 0
    }

    /// `Err(CapacityExceeded)` naming `field` when decoding saw more than `N` elements.
    pub fn check_capacity(
        &self,
        field: &'static str,
    ) -> Result<(), crate::model_error::ModelError> {
        if self.overflowed() {
            Err(crate::model_error::ModelError::CapacityExceeded {
                field,
                len: self.declared_len(),
                max: N,
            })
        } else {
            Ok(())
        }
    }
}

impl<T, const N: usize> BoundedVec<T, N> {
    /// Appends `item`, or counts it past the capacity (what decoding a longer list does).
    pub(crate) fn push_or_count(&mut self, item: T) {
        if self.items.push(item).is_err() {
            self.overflow = self.overflow.saturating_add(1);
        }
    }
}

impl<T: Clone, const N: usize> BoundedVec<T, N> {
    /// Copies `items`; `Err(CapacityExceeded)` if there are more than `N`.
    pub fn from_slice(items: &[T]) -> Result<Self, crate::model_error::ModelError> {
        let mut v = Self::new();
        for item in items {
            if v.items.push(item.clone()).is_err() {
                return Err(crate::model_error::ModelError::CapacityExceeded {
                    field: "list",
                    len: items.len(),
                    max: N,
                });
            }
        }
        Ok(v)
    }
}

impl<T, const N: usize> Deref for BoundedVec<T, N> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        &self.items
    }
}

impl<T: Serialize, const N: usize> Serialize for BoundedVec<T, N> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut seq = serializer.serialize_seq(Some(self.items.len()))?;
        for item in &self.items {
            seq.serialize_element(item)?;
        }
        seq.end()
    }
}

struct BoundedVisitor<T, const N: usize>(PhantomData<T>);

impl<'de, T: Deserialize<'de>, const N: usize> Visitor<'de> for BoundedVisitor<T, N> {
    type Value = BoundedVec<T, N>;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "a sequence")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let mut out = BoundedVec::new();
        // Every element occupies at least one byte, so the loop is bounded by the blob length.
        while let Some(item) = seq.next_element::<T>()? {
            out.push_or_count(item);
        }
        Ok(out)
    }
}

impl<'de, T: Deserialize<'de>, const N: usize> Deserialize<'de> for BoundedVec<T, N> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_seq(BoundedVisitor::<T, N>(PhantomData))
    }
}
