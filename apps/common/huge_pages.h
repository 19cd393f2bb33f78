#pragma once
/// Huge pages for the large arrays of a run.
///
/// A grown tree's stages allocate arrays of tens to hundreds of megabytes (positions,
/// triangles, normals, export buffers). glibc serves each from fresh mmap'd memory, and every
/// 4 KiB page faults on first touch. With glibc's malloc told to back its blocks with
/// transparent huge pages (the tunable `glibc.malloc.hugetlb=1`, glibc 2.35 or later) far
/// fewer pages fault, and the output is the same bytes (docs/defaults.md has the figures).
/// The tunable is only read at program start, so the program re-executes itself once with it
/// set.

namespace sm {

/// Call first thing in main(). Re-executes the program (the path /proc/self/exe names) with `argv` and
/// GLIBC_TUNABLES extended by `glibc.malloc.hugetlb=1`, unless: not Linux with glibc, the
/// kernel's transparent huge pages are off ("[never]"), the tunable is already set, this is
/// the re-executed process, or the environment has STRANDMESH_HUGE_PAGES=0. Returns normally
/// in all those cases and when the re-execution fails (the program then runs as it is).
void reexec_with_huge_pages(char** argv);

/// Whether this process runs with the tunable set by reexec_with_huge_pages.
bool running_with_huge_pages();

/// Call in main() before the pipeline runs. Tells glibc's malloc to keep freed memory for
/// reuse instead of handing it back to the kernel: no block is served by its own mmap
/// (M_MMAP_MAX 0) and the heap is not trimmed (M_TRIM_THRESHOLD 2 GiB, the most it takes).
/// Each stage's large temporaries then reuse pages the previous stage already faulted in,
/// rather than faulting (and the kernel zeroing) fresh ones, at the same peak memory
/// (docs/defaults.md). Does nothing off glibc, or when the environment has
/// STRANDMESH_HUGE_PAGES=0 (the switch for all of this file's tuning).
void keep_freed_memory();

}  // namespace sm
