//! Sparse accessors: a base array (the accessor's buffer view, or zeros without one) with the
//! elements at `sparse.indices` replaced by `sparse.values`, as glTF 2.0 §3.6.2.3 defines.
//! Morph targets that move a few vertices are stored this way.

use super::*;

impl GltfReader<'_, '_> {
    /// Checks `acc`'s sparse part where it has one: its counts, both views inside their
    /// buffers, and indices strictly increasing below the accessor's count (what the
    /// substitution in [`Self::read_floats`] and the `gltf` crate's reader rely on).
    pub(super) fn check_sparse(
        &self,
        acc: &gltf::Accessor,
        at: &Location,
    ) -> Result<(), LoadError> {
        let Some(sparse) = acc.sparse() else {
            return Ok(());
        };
        let n = sparse.count();
        if n == 0 || n > acc.count() {
            return Err(LoadError::invalid(
                at.clone(),
                format!(
                    "sparse.count {n} must be between 1 and the accessor's count {}",
                    acc.count()
                ),
            ));
        }
        let indices = sparse.indices();
        let index_size = indices.index_type().size();
        self.check_span(
            &indices.view(),
            indices.offset(),
            n * index_size,
            at,
            "sparse.indices",
        )?;
        let values = sparse.values();
        self.check_span(
            &values.view(),
            values.offset(),
            n * acc.size(),
            at,
            "sparse.values",
        )?;
        let list = self.sparse_indices(acc).unwrap_or_default();
        for (k, pair) in list.windows(2).enumerate() {
            if pair[1] <= pair[0] {
                return Err(LoadError::invalid(
                    at.clone(),
                    format!(
                        "sparse.indices must increase strictly, but entry {} is {} after {} \
                         (sort the substituted elements by index)",
                        k + 1,
                        pair[1],
                        pair[0]
                    ),
                ));
            }
        }
        if let Some(&last) = list.last() {
            if last as usize >= acc.count() {
                return Err(LoadError::invalid(
                    at.clone(),
                    format!(
                        "sparse.indices names element {last}, but the accessor has {} elements",
                        acc.count()
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Whether `len` bytes from `offset` lie inside `view` and the view inside its buffer.
    fn check_span(
        &self,
        view: &gltf::buffer::View,
        offset: usize,
        len: usize,
        at: &Location,
        what: &str,
    ) -> Result<(), LoadError> {
        let buffer_len = self.buffers.get(view.buffer().index()).map_or(0, Vec::len);
        let need = offset.saturating_add(len);
        if need > view.length() || view.offset().saturating_add(view.length()) > buffer_len {
            return Err(LoadError::invalid(
                at.clone(),
                format!(
                    "{what} reads past the end of its data (needs {need} bytes of buffer view \
                     {}, which has {} and lies at {}..{} of buffer {} with {buffer_len} bytes)",
                    view.index(),
                    view.length(),
                    view.offset(),
                    view.offset() as u128 + view.length() as u128,
                    view.buffer().index()
                ),
            ));
        }
        Ok(())
    }

    /// The element indices `acc`'s sparse part substitutes (checked by
    /// [`Self::check_sparse`]); `None` without a sparse part.
    pub(super) fn sparse_indices(&self, acc: &gltf::Accessor) -> Option<Vec<u32>> {
        use gltf::accessor::sparse::IndexType;
        let sparse = acc.sparse()?;
        let indices = sparse.indices();
        let view = indices.view();
        let buf = self.buffers.get(view.buffer().index())?;
        let ty = indices.index_type();
        let size = ty.size();
        let start = view.offset() + indices.offset();
        let bytes = buf.get(start..start + sparse.count() * size)?;
        Some(
            bytes
                .chunks_exact(size)
                .map(|b| match ty {
                    IndexType::U8 => u32::from(b[0]),
                    IndexType::U16 => u32::from(u16::from_le_bytes([b[0], b[1]])),
                    IndexType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                })
                .collect(),
        )
    }

    /// Where `acc`'s sparse values start in their buffer: (buffer index, byte offset).
    pub(super) fn sparse_values_at(&self, acc: &gltf::Accessor) -> Option<(usize, usize)> {
        let values = acc.sparse()?.values();
        let view = values.view();
        Some((view.buffer().index(), view.offset() + values.offset()))
    }
}
