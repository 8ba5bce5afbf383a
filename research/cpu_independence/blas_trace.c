/* LD_PRELOAD shim: logs every call numpy makes into its bundled OpenBLAS/LAPACK (scipy_openblas64_) with
 * the planetnav frames of the Python stack, once per call site, to stderr; then calls the real function.
 *
 *   gcc -O1 -shared -fPIC -o /tmp/blas_trace.so research/cpu_independence/blas_trace.c -ldl
 *   LD_PRELOAD=/tmp/blas_trace.so python -m pytest tests/env/test_golden.py tests/train/test_training_golden.py -s
 *
 * Found the BLAS calls on the environment's path (see research/README.md, "cpu_independence/").
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdio.h>
#include <stdint.h>
#include <stdlib.h>
#include <link.h>
#include <string.h>
static void *lib = 0;
static int cb(struct dl_phdr_info *info, size_t size, void *data) {
  if (strstr(info->dlpi_name, "scipy_openblas64_")) { lib = dlopen(info->dlpi_name, RTLD_NOW | RTLD_NOLOAD); return 1; }
  return 0; }
static void *real_sym(const char *name) { if (!lib) dl_iterate_phdr(cb, 0); void *p = lib ? dlsym(lib, name) : 0;
  if (!p) { fprintf(stderr, "shim: no %s\n", name); abort(); } return p; }
typedef int (*gil_ensure_t)(void);
typedef void (*gil_release_t)(int);
typedef int (*run_t)(const char*);
static void report(const char *name) {
    gil_ensure_t ens = (gil_ensure_t)dlsym(RTLD_DEFAULT, "PyGILState_Ensure");
    gil_release_t rel = (gil_release_t)dlsym(RTLD_DEFAULT, "PyGILState_Release");
    run_t run = (run_t)dlsym(RTLD_DEFAULT, "PyRun_SimpleString");
    if (!ens || !run) { fprintf(stderr, "BLAS %s (no python)\n", name); return; }
    int g = ens();
    char buf[1200];
    snprintf(buf, sizeof buf,
      "import builtins, traceback, sys\n"
      "_st = builtins.__dict__.setdefault('_blas_seen', set())\n"
      "_fr = [f for f in traceback.extract_stack() if 'planetnav' in f.filename or '/tests/' in f.filename]\n"
      "_k = ('%s',) + tuple((f.filename.split('/')[-1], f.lineno) for f in _fr[-4:])\n"
      "if _k not in _st:\n"
      "    _st.add(_k)\n"
      "    sys.stderr.write('BLAS %s ' + ' <- '.join('%%s:%%d %%s' %% (f.filename.split('main/')[-1], f.lineno, f.name) for f in reversed(_fr[-6:])) + '\\n')\n",
      name, name);
    run(buf);
    rel(g);
}
#define FWD(ret, name, params, args) \
  ret name params { static ret (*real) params = 0; if (!real) real = real_sym(#name); report(#name); return real args; }
#define FWDV(name, params, args) \
  void name params { static void (*real) params = 0; if (!real) real = real_sym(#name); report(#name); real args; }
typedef int64_t I;
FWD(double, scipy_cblas_ddot64_, (I n, const double *x, I incx, const double *y, I incy), (n,x,incx,y,incy))
FWDV(scipy_cblas_dgemv64_, (int o, int t, I m, I n, double a, const double *A, I lda, const double *x, I incx, double b, double *y, I incy), (o,t,m,n,a,A,lda,x,incx,b,y,incy))
FWDV(scipy_cblas_dgemm64_, (int o, int ta, int tb, I m, I n, I k, double a, const double *A, I lda, const double *B, I ldb, double b, double *C, I ldc), (o,ta,tb,m,n,k,a,A,lda,B,ldb,b,C,ldc))
FWDV(scipy_cblas_dsyrk64_, (int o, int u, int t, I n, I k, double a, const double *A, I lda, double b, double *C, I ldc), (o,u,t,n,k,a,A,lda,b,C,ldc))
FWDV(scipy_cblas_daxpy64_, (I n, double a, const double *x, I incx, double *y, I incy), (n,a,x,incx,y,incy))
#define FWDP(name) \
  void name (void*a1,void*a2,void*a3,void*a4,void*a5,void*a6,void*a7,void*a8,void*a9,void*a10,void*a11,void*a12,void*a13,void*a14,void*a15,void*a16) { \
    static void (*real)(void*,void*,void*,void*,void*,void*,void*,void*,void*,void*,void*,void*,void*,void*,void*,void*) = 0; \
    if (!real) real = real_sym(#name); report(#name); real(a1,a2,a3,a4,a5,a6,a7,a8,a9,a10,a11,a12,a13,a14,a15,a16); }
FWDP(scipy_dcopy_64_) FWDP(scipy_dgeev_64_) FWDP(scipy_dgelsd_64_) FWDP(scipy_dgeqrf_64_) FWDP(scipy_dgesdd_64_)
FWDP(scipy_dgesv_64_) FWDP(scipy_dgetrf_64_) FWDP(scipy_dorgqr_64_) FWDP(scipy_dpotrf_64_) FWDP(scipy_dsyevd_64_)
