//! Large buffers: zero-initialised ones (the readers' outputs, the sparse matrices the
//! iterative solvers stream and their work blocks), unzeroed ones for outputs a
//! parallel fill writes once (the operators' CSC arrays); and the allocator settings that
//! decide whether freed buffers go back to the kernel ([`keep_freed_memory`],
//! [`release_free_memory`]).
//!
//! A reader writes its vertex and face arrays once, front to back, right after
//! allocating them: on Linux each 4 KiB page is then faulted in, zeroed and charged
//! one at a time, and for arrays of hundreds of megabytes those faults (which scale
//! poorly across threads) cost more than the parsing. [`zeroed_vec`] asks
//! for transparent huge pages (`madvise(MADV_HUGEPAGE)`, 2 MiB pages: 512 times fewer
//! faults) on the whole 2 MiB-aligned part of a large buffer before it is touched. The
//! advice changes neither the contents nor the lifetime of the memory; where huge
//! pages are unavailable (disabled, other systems) it is ignored and the buffer is an
//! ordinary one.
//!
//! [`Scatter`] lets parallel threads write disjoint, data-dependent positions of one
//! buffer (the scatter step of a counting sort, where a counter hands every item its
//! own slot); [`bucket_sort`] is that counting sort, with a histogram per thread.

/// Buffers from this size on are advised to use huge pages.
const ADVISE_FROM: usize = 4 << 20;

/// `vec![zero; n]`, advised to use transparent huge pages when it is large.
///
/// The advice must come before the first touch of the pages: a page already faulted
/// in stays a 4 KiB page. glibc's `calloc` serves a block from its heap (every block
/// below [`MMAP_THRESHOLD_BYTES`] under [`keep_freed_memory`]) by clearing it with one
/// `memset` on the calling thread, fresh pages included, so `vec![0; n]` followed by
/// the advice would fault every page in 4 KiB at a time, serially. Such a block is
/// therefore allocated without clearing, advised, then filled by the rayon pool (each
/// worker faults in its own part, in 2 MiB pages). A block from the threshold on is
/// mapped on its own, fresh and lazily zeroed by the kernel: `calloc` does not touch
/// it, so it is advised after the allocation and left untouched.
pub(crate) fn zeroed_vec<T: Clone + Send + Sync>(zero: T, n: usize) -> Vec<T> {
    use rayon::prelude::*;
    let bytes = n.saturating_mul(std::mem::size_of::<T>());
    if bytes < ADVISE_FROM {
        return vec![zero; n];
    }
    if bytes >= MMAP_THRESHOLD_BYTES {
        let v = vec![zero; n];
        advise_huge(v.as_ptr() as usize, bytes);
        return v;
    }
    let mut v = advised_capacity::<T>(n);
    v.spare_capacity_mut()[..n]
        .par_chunks_mut((FILL_CHUNK / std::mem::size_of::<T>().max(1)).max(1))
        .for_each(|c| {
            for e in c {
                e.write(zero.clone());
            }
        });
    // SAFETY: the capacity is at least n and elements 0..n were written above.
    unsafe { v.set_len(n) };
    v
}

/// Bytes per task of [`zeroed_vec`]'s parallel fill.
const FILL_CHUNK: usize = 1 << 20;

/// An empty vector with room for `cap` elements, advised to use transparent huge
/// pages when that room is large, for an output written front to back by pushes
/// (which then fault its pages in 2 MiB at a time).
pub(crate) fn advised_capacity<T>(cap: usize) -> Vec<T> {
    let v = Vec::with_capacity(cap);
    let bytes = cap.saturating_mul(std::mem::size_of::<T>());
    if bytes >= ADVISE_FROM {
        advise_huge(v.as_ptr() as usize, bytes);
    }
    v
}

/// A vector of `n` uninitialised elements, advised to use transparent huge pages when
/// it is large, for an output that a parallel fill writes once, front to back in
/// blocks: unlike [`zeroed_vec`], no zeroing pass first. (glibc's `calloc` skips the
/// zeroing only for fresh pages; a block reused from its heap, the usual case from the
/// second call of a program on, is cleared by one `memset` on the calling thread, a
/// serial pass over the whole array before the parallel fill.) Turn it into a `Vec<T>`
/// with [`assume_init_vec`] once every element is written.
pub(crate) fn uninit_vec<T>(n: usize) -> Vec<std::mem::MaybeUninit<T>> {
    let mut v = Vec::with_capacity(n);
    // SAFETY: `MaybeUninit<T>` needs no initialisation and the capacity is n.
    unsafe { v.set_len(n) };
    let bytes = n * std::mem::size_of::<T>();
    if bytes >= ADVISE_FROM {
        advise_huge(v.as_ptr() as usize, bytes);
    }
    v
}

/// `Mat::zeros(nrows, ncols)` with the zeros written by the rayon pool, in blocks of
/// columns. faer's `zeros` writes them on the calling thread: for the partial
/// eigensolver's n × hundreds Krylov bases, Ritz vectors and eigenvectors (gigabytes at
/// a million vertices) that is a serial pass which also takes every page fault of the
/// fresh memory, one 4 KiB page at a time. Here each worker faults in and clears its
/// own columns. Small matrices are left to faer. The same matrix either way.
pub(crate) fn zeroed_mat(nrows: usize, ncols: usize) -> faer::Mat<f64> {
    use rayon::prelude::*;
    /// Elements below which faer's serial fill is used (under Miri 1,024, so that the
    /// matrices it can interpret still take the parallel path; RELIABILITY.md).
    const PARALLEL_FROM: usize = if cfg!(miri) { 1 << 10 } else { 1 << 20 };
    if nrows.saturating_mul(ncols) < PARALLEL_FROM {
        return faer::Mat::zeros(nrows, ncols);
    }
    let mut m = faer::Mat::<f64>::with_capacity(nrows, ncols);
    // The allocation holds `ncols` columns of `stride ≥ nrows` elements each.
    let stride = m.col_stride() as usize;
    assert!(stride >= nrows, "faer's column stride below the row count");
    // SAFETY: the allocation holds `stride · ncols` elements (`with_capacity`), and `m`
    // is not touched until the tasks below, which write disjoint columns, are done.
    let storage = unsafe { Scatter::from_raw_parts(m.as_ptr_mut(), stride * ncols) };
    let per_task = (PARALLEL_FROM / nrows).max(1);
    (0..ncols)
        .into_par_iter()
        .with_min_len(per_task)
        .for_each(|j| {
            // SAFETY: column j's rows, which no other task writes; all-zero bits are
            // 0.0.
            unsafe { storage.zero_bytes(j * stride, nrows) };
        });
    // SAFETY: the capacity is at least nrows × ncols (`with_capacity`), and every
    // element now in bounds — rows 0..nrows of each column — was written above.
    unsafe { m.set_dims(nrows, ncols) };
    m
}

/// Array size, in bytes, from which an array is taken to exceed the cache: twice
/// the 2 MiB L2 per core of the Intel Xeon host it was measured on. From this size on, copies are made in
/// parallel ([`concat`]: below it one thread's `memcpy` beats waking the pool, for
/// the connectivity of meshes up to a few hundred thousand vertices), and scatters
/// prefetch their slots ([`bucket_sort`]: a slot written at random is rarely in
/// cache). BENCHMARKS.md, "Connectivity".
pub(crate) const LARGE_FROM: usize = 4 << 20;

/// The slices `get(p)` of `parts`, in order, in one vector with room for `spare`
/// more elements: copied by the rayon pool, one task per part, into a buffer advised
/// to use huge pages ([`uninit_vec`]) when the total reaches `parallel_from` bytes
/// (the callers pass [`LARGE_FROM`]), else by one `extend_from_slice` per
/// part. The same vector either way.
pub(crate) fn concat<P: Sync, T: Copy + Send + Sync>(
    parts: &[P],
    get: impl Fn(&P) -> &[T] + Sync,
    spare: usize,
    parallel_from: usize,
) -> Vec<T> {
    use rayon::prelude::*;
    let total: usize = parts.iter().map(|p| get(p).len()).sum();
    if total * std::mem::size_of::<T>() < parallel_from {
        let mut v = Vec::with_capacity(total + spare);
        for p in parts {
            v.extend_from_slice(get(p));
        }
        return v;
    }
    let mut v = uninit_vec::<T>(total + spare);
    let mut slots: Vec<&mut [std::mem::MaybeUninit<T>]> = Vec::with_capacity(parts.len());
    let mut rest = &mut v[..total];
    for p in parts {
        let (head, tail) = std::mem::take(&mut rest).split_at_mut(get(p).len());
        slots.push(head);
        rest = tail;
    }
    slots.into_par_iter().zip(parts).for_each(|(slot, p)| {
        for (s, &x) in slot.iter_mut().zip(get(p)) {
            s.write(x);
        }
    });
    v.truncate(total);
    // SAFETY: elements 0..total were written above, one slot per element of a part.
    unsafe { assume_init_vec(v) }
}

/// `items.to_vec()`, copied by the rayon pool in blocks of 1 MiB into a buffer
/// advised to use huge pages when it reaches `parallel_from` bytes ([`concat`]).
pub(crate) fn to_vec<T: Copy + Send + Sync>(items: &[T], parallel_from: usize) -> Vec<T> {
    const BLOCK: usize = 1 << 20;
    let step = (BLOCK / std::mem::size_of::<T>().max(1)).max(1);
    let blocks: Vec<&[T]> = items.chunks(step).collect();
    concat(&blocks, |b| b, 0, parallel_from)
}

/// The `Vec<T>` of an [`uninit_vec`] whose every element has been written.
///
/// # Safety
/// Every element of `v` must be initialised.
pub(crate) unsafe fn assume_init_vec<T>(v: Vec<std::mem::MaybeUninit<T>>) -> Vec<T> {
    let mut v = std::mem::ManuallyDrop::new(v);
    let (ptr, len, cap) = (v.as_mut_ptr(), v.len(), v.capacity());
    // SAFETY: `MaybeUninit<T>` has the layout of `T`; the allocation is the one of `v`
    // (not dropped: ManuallyDrop), and the caller guarantees every element is written.
    unsafe { Vec::from_raw_parts(ptr.cast::<T>(), len, cap) }
}

/// `s` as initialised, once every element has been written.
///
/// # Safety
/// Every element of `s` must be initialised.
#[inline]
pub(crate) unsafe fn assume_init_slice<T>(s: &mut [std::mem::MaybeUninit<T>]) -> &mut [T] {
    // SAFETY: the caller guarantees every element is initialised; `MaybeUninit<T>`
    // has the layout of `T`.
    unsafe { &mut *(s as *mut [std::mem::MaybeUninit<T>] as *mut [T]) }
}

#[cfg(target_os = "linux")]
fn advise_huge(start: usize, len: usize) {
    const HUGE: usize = 2 << 20;
    let from = start.next_multiple_of(HUGE);
    let to = (start + len) / HUGE * HUGE;
    if to > from {
        // SAFETY: [from, to) lies inside the buffer just allocated, which this thread
        // owns; MADV_HUGEPAGE only changes how its pages will be backed, never their
        // contents, and a failure (THP disabled, EINVAL) leaves it untouched.
        unsafe {
            libc::madvise(from as *mut libc::c_void, to - from, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn advise_huge(_start: usize, _len: usize) {}

/// Returns the allocator's free memory to the system: glibc's `malloc_trim(0)`, which
/// releases every whole free page of its heaps, not only the top. glibc otherwise keeps
/// freed blocks below its (adaptive, up to 32 MiB) mmap threshold in its heaps, so
/// dropping a large structure in the middle of a long job would not lower the
/// resident memory of what follows. Called once a large structure is freed (the
/// compressor's input connectivity); costs a walk of the free lists. A no-op on
/// other systems.
pub(crate) fn release_free_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only returns free pages of the allocator's own heaps to the
    // kernel; it touches no live allocation.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// The free memory, in bytes, that [`keep_freed_memory`] asks glibc to keep at the top
/// of each of its heaps: two dense 2,000 × 2,000 matrices' worth.
pub const KEEP_FREED_BYTES: usize = 64 << 20;

/// The block size from which [`keep_freed_memory`] has glibc map a block on its own
/// (`M_MMAP_THRESHOLD`): 32 MiB, the largest value glibc's own adaptive threshold
/// reaches. Smaller blocks come from the heaps and are reused there.
pub const MMAP_THRESHOLD_BYTES: usize = 32 << 20;

/// Asks the process' allocator to reuse freed memory instead of returning it to the
/// kernel at once: glibc keeps up to [`KEEP_FREED_BYTES`] of free memory at the top of
/// each heap (`mallopt(M_TOP_PAD)`) and serves every block below
/// [`MMAP_THRESHOLD_BYTES`] from its heaps (`mallopt(M_MMAP_THRESHOLD)`). Returns
/// whether the allocator took both settings (`false` on systems without glibc, where
/// nothing changes).
///
/// **Why.** A program that computes one result after another (a loop over patches or
/// meshes, a benchmark) allocates the same buffers again and again. Memory that glibc
/// returned to the kernel is page-faulted and zeroed again, 4 KiB at a time, on the
/// next use, a cost comparable to the work itself for the sparse operators' arrays
/// and a noticeable share of a small dense eigendecomposition (measured in
/// BENCHMARKS.md). Two glibc behaviours return it: the heaps give every freed block at
/// their top back (hence the pad), and blocks from the mmap threshold on are mapped
/// and unmapped on their own. Setting the pad also freezes that threshold at its
/// initial 128 KiB (glibc stops adapting it once any of these parameters is set),
/// so the pad alone would send every block above 128 KiB to the kernel on free;
/// hence the threshold is set too, to the ceiling of glibc's adaptive one.
///
/// **Cost.** Up to [`KEEP_FREED_BYTES`] of freed memory stays resident per heap (one
/// per thread that allocated), so a later peak that the heap cannot serve from it
/// can be that much higher per heap. Blocks from [`MMAP_THRESHOLD_BYTES`] on (the
/// large meshes' arrays, big dense matrices) are mapped on their own and returned at
/// once, as before. The setting is process-wide, so the library never makes it on its
/// own: the `meshlap` binaries call this at start, and the Python package offers it as
/// `meshlap.keep_freed_memory()` (its extension's own allocations come from mimalloc,
/// which reuses freed memory without it).
pub fn keep_freed_memory() -> bool {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        // SAFETY: mallopt only changes tuning parameters of the allocator; it touches
        // no allocation. Both take an int; the values fit.
        unsafe {
            let pad = libc::mallopt(libc::M_TOP_PAD, KEEP_FREED_BYTES as libc::c_int) == 1;
            let map =
                libc::mallopt(libc::M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES as libc::c_int) == 1;
            pad && map
        }
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    {
        false
    }
}

/// Parallel writes into distinct positions of a slice: the scatter of a counting
/// sort, whose slots come from per-thread or atomic counters, so no two writers
/// share one.
/// Holding the `&mut` borrow for `'a` keeps everyone else out.
pub(crate) struct Scatter<'a, T> {
    ptr: *mut T,
    len: usize,
    _borrow: std::marker::PhantomData<&'a mut [T]>,
}

// SAFETY: the slice is borrowed mutably for 'a; `write` requires distinct indices,
// so threads never touch the same element.
unsafe impl<T: Send> Send for Scatter<'_, T> {}
unsafe impl<T: Send> Sync for Scatter<'_, T> {}

impl<'a, T: Copy> Scatter<'a, T> {
    pub(crate) fn new(slice: &'a mut [T]) -> Self {
        Self {
            ptr: slice.as_mut_ptr(),
            len: slice.len(),
            _borrow: std::marker::PhantomData,
        }
    }

    /// A `Scatter` over `len` elements from `ptr`, which may be uninitialised (for
    /// [`Scatter::zero_bytes`]).
    ///
    /// # Safety
    /// `ptr..ptr + len` must be one allocation valid for writes for `'a`, used by no
    /// one else while the `Scatter` lives.
    pub(crate) unsafe fn from_raw_parts(ptr: *mut T, len: usize) -> Self {
        Self {
            ptr,
            len,
            _borrow: std::marker::PhantomData,
        }
    }

    /// Sets the bytes of elements `start..start + count` to zero (panics if out of
    /// bounds).
    ///
    /// # Safety
    /// No other thread may read or write those elements while the `Scatter` lives.
    #[inline]
    pub(crate) unsafe fn zero_bytes(&self, start: usize, count: usize) {
        assert!(
            start.checked_add(count).is_some_and(|end| end <= self.len),
            "scatter range {start}+{count} out of bounds ({})",
            self.len
        );
        // SAFETY: in bounds (checked), and the caller guarantees exclusive use.
        unsafe { std::ptr::write_bytes(self.ptr.add(start), 0, count) }
    }

    /// Asks the CPU to bring element `i`'s cache line closer before it is written
    /// ([`prefetch`]); nothing when `i` is out of bounds. A hint: no effect on
    /// any value, and safe, since nothing is read or written.
    #[inline(always)]
    pub(crate) fn prefetch(&self, i: usize) {
        if i < self.len {
            // SAFETY: in bounds, so `add` stays inside the allocation; the reference
            // only names the address for the hint and is never read through.
            prefetch(unsafe { &*self.ptr.add(i) });
        }
    }

    /// Writes `value` at `i` (panics if out of bounds).
    ///
    /// # Safety
    /// No other thread may read or write index `i` while the `Scatter` lives.
    #[inline]
    pub(crate) unsafe fn write(&self, i: usize, value: T) {
        assert!(
            i < self.len,
            "scatter index {i} out of bounds ({})",
            self.len
        );
        // SAFETY: in bounds (checked), and the caller guarantees exclusive use of i.
        unsafe { self.ptr.add(i).write(value) }
    }
}

/// How many items ahead a scatter prefetches its slots (32 and 64 measured alike on
/// icosphere 9's connectivity, 8 and 12 slower).
pub(crate) const SCATTER_PREFETCH_AHEAD: usize = 32;

/// Counting sort of `items` items, item `i` giving the `K` entries `entry(i)` as
/// (bucket, value), into `n` buckets: the bucket starts (`n + 1`, the last the total
/// `K·items`) and the values, bucket by bucket, each bucket in item order. Each
/// thread counts and scatters its own contiguous range of items with its own
/// histogram (no atomic counters, which cost more than the rest on a few cores);
/// the result does not depend on the thread count. `entry` runs twice per item, and a
/// third time when the output reaches [`LARGE_FROM`] bytes: the scatter
/// then asks for the slots of the item [`SCATTER_PREFETCH_AHEAD`] items ahead
/// ([`Scatter::prefetch`]) before writing the current one, so that its writes to
/// slots scattered over the output do not wait on memory one after another
/// (BENCHMARKS.md, "Connectivity").
/// Panics if a bucket is `n` or more, or if `K·items` exceeds `u32::MAX`.
pub(crate) fn bucket_sort<const K: usize, T: Copy + Send + Sync>(
    n: usize,
    items: usize,
    zero: T,
    entry: impl Fn(usize) -> [(u32, T); K] + Sync,
) -> (Vec<u32>, Vec<T>) {
    use rayon::prelude::*;
    let total = K * items;
    assert!(u32::try_from(total).is_ok(), "bucket_sort: {total} entries");
    // At least 2^15 items per range, one range per thread.
    let parts = rayon::current_num_threads().clamp(1, items.div_ceil(1 << 15).max(1));
    let ranges: Vec<std::ops::Range<usize>> = (0..parts)
        .map(|p| p * items / parts..(p + 1) * items / parts)
        .collect();
    let mut hist: Vec<Vec<u32>> = ranges
        .par_iter()
        .map(|r| {
            let mut h = vec![0u32; n];
            for i in r.clone() {
                for (b, _) in entry(i) {
                    h[b as usize] += 1;
                }
            }
            h
        })
        .collect();
    // Bucket starts, and each range's first slot per bucket (in place of its counts).
    let mut start = vec![0u32; n + 1];
    let mut at = 0u32;
    for (b, s) in start[..n].iter_mut().enumerate() {
        *s = at;
        for h in hist.iter_mut() {
            let c = h[b];
            h[b] = at;
            at += c;
        }
    }
    start[n] = at;
    let mut out = zeroed_vec(zero, total);
    {
        let scatter = Scatter::new(&mut out);
        let ahead = if total * std::mem::size_of::<T>() >= LARGE_FROM {
            SCATTER_PREFETCH_AHEAD
        } else {
            0
        };
        ranges.into_par_iter().zip(&mut hist).for_each(|(r, fill)| {
            let end = r.end;
            for i in r {
                if ahead > 0 && i + ahead < end {
                    for (b, _) in entry(i + ahead) {
                        // The slot as it stands: an entry of the same bucket written
                        // in between moves it by one, which only makes the hint late.
                        scatter.prefetch(fill[b as usize] as usize);
                    }
                }
                for (b, v) in entry(i) {
                    let p = fill[b as usize];
                    fill[b as usize] += 1;
                    // SAFETY: every entry gets its own slot: the ranges' slots of a
                    // bucket are disjoint and each counter only grows.
                    unsafe { scatter.write(p as usize, v) };
                }
            }
        });
    }
    (start, out)
}

/// Asks the CPU to bring `x`'s cache line closer (x86-64; elsewhere nothing). A hint:
/// no effect on any value.
#[inline(always)]
pub(crate) fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        // SAFETY: SSE is part of x86-64, and a prefetch reads nothing the program
        // sees, of an address that is a valid reference here.
        unsafe { _mm_prefetch::<_MM_HINT_T0>((x as *const T).cast::<i8>()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}

#[cfg(test)]
mod tests {
    #[test]
    fn zeroed_mat_is_zero_and_usable_at_any_size() {
        // Both sides of `PARALLEL_FROM` (2^10 elements under Miri, 2^20 otherwise),
        // tall and wide.
        let p = if cfg!(miri) { 10 } else { 20 };
        let many_columns = if cfg!(miri) { (30, 40) } else { (1000, 2000) };
        for (n, k) in [
            (0, 0),
            (3, 2),
            many_columns,
            ((1 << p) + 3, 3),
            (1 << (p + 1), 1),
        ] {
            let mut m = super::zeroed_mat(n, k);
            assert_eq!((m.nrows(), m.ncols()), (n, k));
            assert!((0..k).all(|j| m.col(j).iter().all(|&x| x == 0.0)));
            if n > 0 && k > 0 {
                m[(n - 1, k - 1)] = 1.0;
                assert_eq!(m.sum(), 1.0);
            }
        }
    }

    /// `concat` and `to_vec` give `slice::concat`'s vector, empty parts included, on
    /// the sequential and the parallel path and on 1 and 3 threads, with the room
    /// asked for.
    #[test]
    fn concat_and_to_vec_copy_in_order_on_both_paths() {
        let parts: Vec<Vec<u64>> = [0usize, 5, 0, 1, 70_000, 3, 0, 200_001]
            .iter()
            .enumerate()
            .map(|(p, &len)| (0..len as u64).map(|i| (p as u64) << 40 | i).collect())
            .collect();
        let want: Vec<u64> = parts.concat();
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for from in [0, usize::MAX] {
                let got = pool.install(|| super::concat(&parts, |p| &p[..], 2, from));
                assert_eq!(got, want, "{threads} threads, from {from}");
                assert!(got.capacity() >= want.len() + 2);
                let copy = pool.install(|| super::to_vec(&want, from));
                assert_eq!(copy, want);
            }
        }
        assert!(super::concat(&[] as &[Vec<u8>], |p| &p[..], 1, 0).is_empty());
    }

    #[test]
    fn zeroed_vec_is_zero_at_any_size() {
        for n in [0, 1, 1000, (5 << 20) / 12 + 7] {
            let v = super::zeroed_vec([0u32; 3], n);
            assert_eq!(v.len(), n);
            assert!(v.iter().all(|t| *t == [0; 3]));
        }
    }

    #[test]
    fn glibc_takes_the_settings_and_serves_mid_sized_blocks_from_its_heaps() {
        // Process-wide but harmless for the other tests: only where blocks come from
        // and how much freed memory the heaps keep change.
        let took = super::keep_freed_memory();
        assert_eq!(took, cfg!(all(target_os = "linux", target_env = "gnu")));
        // Freed and allocated again, a block is still zeroed by `vec!`.
        drop(super::zeroed_vec(1.0f64, 1 << 20));
        let v = super::zeroed_vec(0.0f64, 1 << 20);
        assert!(v.iter().all(|&x| x == 0.0));
        #[cfg(all(target_os = "linux", target_env = "gnu", target_pointer_width = "64"))]
        {
            // A block glibc maps on its own spans whole pages: `malloc_usable_size`
            // then gives the request rounded up to a page less the chunk's header
            // (24 MiB + 4,080 bytes here), where a block from a heap gives the
            // request rounded up to 16 bytes plus 8 (24 MiB + 8). Three 24 MiB blocks
            // held at once outgrow any heap's padded top; with M_TOP_PAD alone (which
            // freezes the mmap threshold at 128 KiB) the one that does not fit is
            // mapped, and unmapped on free.
            const REQUEST: usize = 24 << 20;
            let blocks: Vec<Vec<u8>> = (0..3).map(|_| Vec::with_capacity(REQUEST)).collect();
            for b in &blocks {
                // SAFETY: the pointer is a live block from malloc (Rust's global
                // allocator on this target, for an alignment of 1).
                let usable = unsafe { libc::malloc_usable_size(b.as_ptr() as *mut libc::c_void) };
                assert!(usable >= REQUEST, "{usable} usable bytes");
                assert!(
                    usable - REQUEST < 16,
                    "a 24 MiB block was mapped on its own ({usable} usable bytes)"
                );
            }
        }
    }

    /// Buckets hold their entries in item order, on pools of 1 and 3 threads alike,
    /// with enough items for several ranges; the second size's output (4.8 MB) is
    /// past [`super::LARGE_FROM`], so its scatter prefetches.
    #[test]
    fn bucket_sort_is_stable_and_thread_independent() {
        for (n, items) in [(1000usize, 100_000usize), (300_000, 300_000)] {
            assert_eq!(items < 200_000, 16 * items < super::LARGE_FROM);
            let key = |i: usize| ((i * 7919) % n) as u32;
            let run = |threads| {
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap()
                    .install(|| {
                        super::bucket_sort(n, items, 0u64, |i| {
                            [(key(i), i as u64), (key(i + 1), (i as u64) << 32)]
                        })
                    })
            };
            let (start, out) = run(3);
            assert_eq!(run(1), (start.clone(), out.clone()));
            // The same as a sequential stable sort by bucket.
            let mut want: Vec<(u32, u64)> = (0..items)
                .flat_map(|i| [(key(i), i as u64), (key(i + 1), (i as u64) << 32)])
                .collect();
            want.sort_by_key(|e| e.0);
            assert_eq!(out, want.iter().map(|e| e.1).collect::<Vec<_>>());
            let mut len = vec![0usize; n];
            want.iter().for_each(|e| len[e.0 as usize] += 1);
            for b in 0..n {
                assert_eq!((start[b + 1] - start[b]) as usize, len[b]);
            }
        }
    }
}
