/* LD_PRELOAD shim for CI: every block from malloc, posix_memalign and
 * aligned_alloc comes back filled with 0xFF bytes, which read as a float64
 * (and float32) NaN. np.empty in numpy and in numba's kernels gets its memory
 * this way, so a work array read before it is written turns the result NaN
 * instead of depending on what the allocator happened to hand out (CI once
 * gave the smoother NaN garbage that this machine's allocator never did).
 * calloc is left alone: zeroed memory stays zeroed.
 *
 *   gcc -O2 -shared -fPIC tools/nan_malloc.c -o nan_malloc.so -ldl
 *   LD_PRELOAD=$PWD/nan_malloc.so python -m pytest ...
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stddef.h>
#include <string.h>

static void *(*real_malloc)(size_t);
static int (*real_posix_memalign)(void **, size_t, size_t);
static void *(*real_aligned_alloc)(size_t, size_t);

void *malloc(size_t n)
{
    if (!real_malloc)
        real_malloc = (void *(*)(size_t))dlsym(RTLD_NEXT, "malloc");
    void *p = real_malloc(n);
    if (p)
        memset(p, 0xff, n);
    return p;
}

int posix_memalign(void **pp, size_t align, size_t n)
{
    if (!real_posix_memalign)
        real_posix_memalign = (int (*)(void **, size_t, size_t))dlsym(RTLD_NEXT,
                                                                      "posix_memalign");
    int r = real_posix_memalign(pp, align, n);
    if (r == 0 && *pp)
        memset(*pp, 0xff, n);
    return r;
}

void *aligned_alloc(size_t align, size_t n)
{
    if (!real_aligned_alloc)
        real_aligned_alloc = (void *(*)(size_t, size_t))dlsym(RTLD_NEXT, "aligned_alloc");
    void *p = real_aligned_alloc(align, n);
    if (p)
        memset(p, 0xff, n);
    return p;
}
