#pragma once
/// Huge pages for the large arrays of a run.
///
/// A grown tree's stages allocate arrays of tens to hundreds of megabytes (positions,
/// triangles, normals, export buffers). glibc serves each from fresh mmap'd memory, and every
/// 4 KiB page faults on first touch: measured with `perf` on this project's machine (a
/// paravirtualised VM), 27% of `strandmesh mesh` on the large preset was page faults. With
/// glibc's malloc told to back its blocks with transparent huge pages (the tunable
/// `glibc.malloc.hugetlb=1`, glibc 2.35 or later), the same run took 3.6-4.0 s instead of
/// 6.7 s, with byte-identical output. The tunable is only read at program start, so the
/// program re-executes itself once with it set.

namespace sm {

/// Call first thing in main(). Re-executes the program (the path /proc/self/exe names) with `argv` and
/// GLIBC_TUNABLES extended by `glibc.malloc.hugetlb=1`, unless: not Linux with glibc, the
/// kernel's transparent huge pages are off ("[never]"), the tunable is already set, this is
/// the re-executed process, or the environment has STRANDMESH_HUGE_PAGES=0. Returns normally
/// in all those cases and when the re-execution fails (the program then runs as it is).
void reexec_with_huge_pages(char** argv);

/// Whether this process runs with the tunable set by reexec_with_huge_pages.
bool running_with_huge_pages();

}  // namespace sm
