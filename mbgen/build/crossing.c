/* The Python crossing of compiled models: one callable per generated function.
 *
 * A CPython extension of its own, compiled once per cache, Python and NumPy
 * (mbgen.build.extension.crossing_module); a model is a plain shared library without
 * Python in it.  entry(request) makes an "entry": a Python callable with the generated
 * function's call signature, call(t, x, p=None, r=None), that takes the common case --
 * a float t, C-contiguous float64 1-D arrays of the right length (exactly np.ndarray,
 * not a subclass), p and r None or such arrays -- straight to <prefix>_<output> (whose
 * address the request gives) and returns a new float64 array of the output's shape.  For
 * anything else (another type or dtype, a wrong length, a stride, keywords, a missing
 * default) and whenever the C function returns a non-zero status, it returns what its
 * fallback (the Python path) returns for the same arguments, so every conversion and
 * every error is the Python path's own.
 *
 * Why: through cffi, one call cost about 1.3 us at n = 2 (two ffi.from_buffer, np.empty,
 * the Python-level checks and cffi's own call), against about 30 ns of C.  Here the
 * checks are a few field reads of the array objects, the output comes from
 * PyArray_SimpleNew, and the C function is called directly.
 *
 * Memory: an array's data pointer is read at every call, never kept (an array may be
 * reallocated in place between calls); only the default p and r, owned by the entry,
 * are the same arrays from call to call; the model's library stays loaded as long as the
 * entry's fallback (which holds the library) lives.  The GIL is held while the entry
 * reads the arrays and, unless the entry was made with release set, while the C function
 * runs.
 *
 * The build defines MBGEN_CROSSING_INIT (PyInit_<module name>) and MBGEN_CROSSING_NAME
 * (the module's name, a hash of what it is built from) and adds NumPy's headers. */

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>
#include <structmember.h>
#include <stddef.h>
#include <stdint.h>

/* Which of p and r the generated function takes (its signature). */
#define MBGEN_TAKES_P 1
#define MBGEN_TAKES_R 2

typedef int (*mbgen_f_x)(double, const double *, double *);
typedef int (*mbgen_f_xa)(double, const double *, const double *, double *);
typedef int (*mbgen_f_xpr)(double, const double *, const double *, const double *, double *);

typedef struct {
    PyObject_HEAD
    vectorcallfunc vectorcall;
    void (*fn)(void);           /* <prefix>_<output>, of the type that takes names */
    int takes, release, out_nd;
    npy_intp n_x, n_p, n_r, out_dims[2];
    PyObject *fallback;         /* the Python path: call(t, x, p=None, r=None) */
    PyObject *p_default;        /* NULL or the entry's own float64 (n_p,) array */
    PyObject *r_default;        /* NULL or the entry's own float64 (n_r,) array */
    PyObject *name;
} mbgen_entry;

static PyArray_Descr *mbgen_f64;   /* np.dtype(np.float64); set by mbgen_setup */

/* A float64 (not byte-swapped) ndarray, exactly, of shape (n,) and stride 8: the Python
 * path's test "a.__class__ is ndarray and a.dtype is F64 and a.shape == (n,) and
 * a.strides == (8,)". */
static int mbgen_vector(PyObject *a, npy_intp n)
{
    PyArrayObject *v = (PyArrayObject *)a;
    return Py_TYPE(a) == &PyArray_Type && PyArray_DESCR(v) == mbgen_f64 && PyArray_NDIM(v) == 1
           && PyArray_DIMS(v)[0] == n && PyArray_STRIDES(v)[0] == (npy_intp)sizeof(double);
}

static int mbgen_run(const mbgen_entry *e, double t, const double *x, const double *p,
                     const double *r, double *out)
{
    switch (e->takes) {
    case MBGEN_TAKES_P | MBGEN_TAKES_R:
        return ((mbgen_f_xpr)e->fn)(t, x, p, r, out);
    case MBGEN_TAKES_P:
        return ((mbgen_f_xa)e->fn)(t, x, p, out);
    case MBGEN_TAKES_R:
        return ((mbgen_f_xa)e->fn)(t, x, r, out);
    default:
        return ((mbgen_f_x)e->fn)(t, x, out);
    }
}

static PyObject *mbgen_entry_call(PyObject *self, PyObject *const *args, size_t nargsf,
                                  PyObject *kwnames)
{
    const mbgen_entry *e = (const mbgen_entry *)self;
    const Py_ssize_t nargs = PyVectorcall_NARGS(nargsf);
    const double *p = NULL, *r = NULL;
    PyObject *out;
    int status;

    if (nargs < 2 || nargs > 4 || (kwnames != NULL && PyTuple_GET_SIZE(kwnames) != 0)
        || !PyFloat_CheckExact(args[0]) || !mbgen_vector(args[1], e->n_x))
        goto python;
    if (e->takes & MBGEN_TAKES_P) {
        PyObject *a = nargs > 2 ? args[2] : Py_None;
        if (a == Py_None)
            a = e->p_default;           /* NULL: no default for every parameter */
        if (a == NULL || !mbgen_vector(a, e->n_p))
            goto python;
        p = (const double *)PyArray_DATA((PyArrayObject *)a);
    }
    if (e->takes & MBGEN_TAKES_R) {
        PyObject *a = nargs > 3 ? args[3] : Py_None;
        if (a == Py_None)
            a = e->r_default;
        if (a == NULL || !mbgen_vector(a, e->n_r))
            goto python;
        r = (const double *)PyArray_DATA((PyArrayObject *)a);
    }
    out = PyArray_SimpleNew(e->out_nd, (npy_intp *)e->out_dims, NPY_DOUBLE);
    if (out == NULL)
        return NULL;
    {
        const double t = PyFloat_AS_DOUBLE(args[0]);
        const double *x = (const double *)PyArray_DATA((PyArrayObject *)args[1]);
        double *o = (double *)PyArray_DATA((PyArrayObject *)out);
        if (e->release) {
            Py_BEGIN_ALLOW_THREADS
            status = mbgen_run(e, t, x, p, r, o);
            Py_END_ALLOW_THREADS
        } else {
            status = mbgen_run(e, t, x, p, r, o);
        }
    }
    if (status == 0)
        return out;
    Py_DECREF(out);   /* the Python path calls the function again and raises its error */
python:
    return PyObject_Vectorcall(e->fallback, args, nargsf, kwnames);
}

static int mbgen_entry_traverse(PyObject *self, visitproc visit, void *arg)
{
    mbgen_entry *e = (mbgen_entry *)self;
    Py_VISIT(e->fallback);
    Py_VISIT(e->p_default);
    Py_VISIT(e->r_default);
    Py_VISIT(e->name);
    return 0;
}

static int mbgen_entry_clear(PyObject *self)
{
    mbgen_entry *e = (mbgen_entry *)self;
    Py_CLEAR(e->fallback);
    Py_CLEAR(e->p_default);
    Py_CLEAR(e->r_default);
    Py_CLEAR(e->name);
    return 0;
}

static void mbgen_entry_dealloc(PyObject *self)
{
    PyObject_GC_UnTrack(self);
    mbgen_entry_clear(self);
    PyObject_GC_Del(self);
}

static PyObject *mbgen_entry_repr(PyObject *self)
{
    return PyUnicode_FromFormat("<mbgen C entry %S>", ((mbgen_entry *)self)->name);
}

static PyMemberDef mbgen_entry_members[] = {
    {"fallback", T_OBJECT_EX, offsetof(mbgen_entry, fallback), READONLY,
     "the Python path, called for everything but the common case"},
    {"release_gil", T_INT, offsetof(mbgen_entry, release), READONLY,
     "1 when the GIL is released around the C function"},
    {NULL, 0, 0, 0, NULL}
};

/* Called as vectorcall (CPython's fast calling convention); tp_call, for callers that
 * build a tuple and a dict, goes through the same function (PyVectorcall_Call). */
static PyTypeObject mbgen_entry_type = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "mbgen_entry",
    .tp_basicsize = sizeof(mbgen_entry),
    .tp_dealloc = mbgen_entry_dealloc,
    .tp_vectorcall_offset = offsetof(mbgen_entry, vectorcall),
    .tp_repr = mbgen_entry_repr,
    .tp_call = PyVectorcall_Call,
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC | Py_TPFLAGS_HAVE_VECTORCALL,
    .tp_doc = "call(t, x, p=None, r=None): a generated function, the common case in C "
              "(mbgen.runtime.crossing)",
    .tp_traverse = mbgen_entry_traverse,
    .tp_clear = mbgen_entry_clear,
    .tp_members = mbgen_entry_members,
};

/* NumPy's C API and the entry type, once per module (the GIL is held). */
static int mbgen_setup(void)
{
    if (mbgen_f64 != NULL)
        return 0;
    if (_import_array() < 0 || PyType_Ready(&mbgen_entry_type) < 0)
        return -1;
    mbgen_f64 = PyArray_DescrFromType(NPY_DOUBLE);
    return mbgen_f64 == NULL ? -1 : 0;
}

/* A default array, checked here so that a call can use it unchecked; None: NULL. */
static int mbgen_default(PyObject *a, npy_intp n, const char *what, PyObject **slot)
{
    if (a == Py_None)
        return 0;
    if (!mbgen_vector(a, n) || !PyArray_ISCARRAY_RO((PyArrayObject *)a)) {
        PyErr_Format(PyExc_ValueError, "the default %s must be a float64 array of shape "
                     "(%zd,)", what, (Py_ssize_t)n);
        return -1;
    }
    Py_INCREF(a);
    *slot = a;
    return 0;
}

static int mbgen_make(PyObject *request)
{
    PyObject *fallback, *p_default, *r_default, *shape, *name, *sink, *made;
    unsigned long long address;
    int takes, release;
    Py_ssize_t n_x, n_p, n_r, rows = 0, cols = 0;
    mbgen_entry *e;

    if (mbgen_setup() < 0)
        return -1;
    if (!PyArg_ParseTuple(request, "OOOKinnnO!pUO!:entry", &fallback, &p_default,
                          &r_default, &address, &takes, &n_x, &n_p, &n_r, &PyTuple_Type, &shape,
                          &release, &name, &PyList_Type, &sink))
        return -1;
    if (!PyArg_ParseTuple(shape, "n|n:output shape", &rows, &cols))
        return -1;
    if (address == 0 || takes < 0 || takes > 3 || !PyCallable_Check(fallback) || n_x < 0
        || n_p < 0 || n_r < 0 || rows < 0 || cols < 0) {
        PyErr_SetString(PyExc_ValueError, "entry: bad request");
        return -1;
    }
    e = PyObject_GC_New(mbgen_entry, &mbgen_entry_type);
    if (e == NULL)
        return -1;
    e->vectorcall = mbgen_entry_call;
    e->fn = (void (*)(void))(uintptr_t)address;
    e->takes = takes;
    e->release = release;
    e->n_x = n_x;
    e->n_p = n_p;
    e->n_r = n_r;
    e->out_nd = (int)PyTuple_GET_SIZE(shape);
    e->out_dims[0] = rows;
    e->out_dims[1] = cols;
    Py_INCREF(fallback);
    e->fallback = fallback;
    e->p_default = e->r_default = NULL;
    Py_INCREF(name);
    e->name = name;
    PyObject_GC_Track((PyObject *)e);
    made = (PyObject *)e;
    if (mbgen_default(p_default, n_p, "p", &e->p_default) < 0
        || mbgen_default(r_default, n_r, "r", &e->r_default) < 0
        || PyList_Append(sink, made) < 0) {
        Py_DECREF(made);
        return -1;
    }
    Py_DECREF(made);
    return 0;
}

/* entry(request): ``request`` is the tuple (fallback, p_default, r_default, function
 * address, takes, n_x, n_p, n_r, output shape, release, name, sink); the entry is
 * appended to the list ``sink`` and returned. */
static PyObject *mbgen_entry_new(PyObject *module, PyObject *request)
{
    PyObject *sink, *made;
    (void)module;
    if (!PyTuple_Check(request) || PyTuple_GET_SIZE(request) != 12) {
        PyErr_SetString(PyExc_TypeError, "entry: the request is a tuple of 12 items");
        return NULL;
    }
    if (mbgen_make(request) < 0)
        return NULL;
    sink = PyTuple_GET_ITEM(request, 11);
    made = PyList_GET_ITEM(sink, PyList_GET_SIZE(sink) - 1);
    Py_INCREF(made);
    return made;
}

static PyMethodDef mbgen_crossing_methods[] = {
    {"entry", mbgen_entry_new, METH_O,
     "entry(request) -> the C entry of one generated function (mbgen.runtime.crossing)"},
    {NULL, NULL, 0, NULL}
};

static struct PyModuleDef mbgen_crossing_module = {
    PyModuleDef_HEAD_INIT, MBGEN_CROSSING_NAME,
    "mbgen's Python crossing: C entries of generated functions", -1, mbgen_crossing_methods,
    NULL, NULL, NULL, NULL
};

PyMODINIT_FUNC MBGEN_CROSSING_INIT(void);

PyMODINIT_FUNC MBGEN_CROSSING_INIT(void)
{
    if (mbgen_setup() < 0)
        return NULL;
    return PyModule_Create(&mbgen_crossing_module);
}
