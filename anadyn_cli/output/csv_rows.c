/* anadyn_csv_rows: the rows of a CSV table in one loop; see
   anadyn_cli/output/csv_table.py.

   rows(table) -> str: table is a 2-D, C-contiguous array of doubles (any object
   with that buffer); each row its numbers joined by ",", ended by "\n".  Each
   number is the text Python's repr gives a float (PyOS_double_to_string with
   'r' and Py_DTSF_ADD_DOT_0, as float.__repr__ calls it: the shortest text
   that reads back to the same double, "inf", "-inf", "nan"), a negative zero
   written "0.0".  No rows or no columns: "". */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <string.h>

static PyObject *py_rows(PyObject *self, PyObject *table) {
    Py_buffer view;
    if (PyObject_GetBuffer(table, &view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0)
        return NULL;
    if (view.ndim != 2 || view.itemsize != (Py_ssize_t)sizeof(double) || view.format == NULL
        || strcmp(view.format, "d") != 0) {
        PyBuffer_Release(&view);
        PyErr_SetString(PyExc_TypeError, "rows: expected a 2-D C-contiguous array of doubles");
        return NULL;
    }
    const double *x = (const double *)view.buf;
    Py_ssize_t count = view.shape[0] * view.shape[1], columns = view.shape[1];
    size_t cap = 64, used = 0;
    if (count > 0 && (size_t)count < ((size_t)PY_SSIZE_T_MAX - 64) / 24)
        cap += (size_t)count * 24;         /* most numbers are shorter: rarely regrown */
    char *out = count > 0 ? PyMem_Malloc(cap) : NULL;
    if (count > 0 && out == NULL) {
        PyBuffer_Release(&view);
        return PyErr_NoMemory();
    }
    Py_ssize_t column = 0;
    for (Py_ssize_t i = 0; i < count; i++) {
        double value = x[i] == 0.0 ? 0.0 : x[i];       /* -0.0 -> 0.0 */
        char *text = PyOS_double_to_string(value, 'r', 0, Py_DTSF_ADD_DOT_0, NULL);
        if (text == NULL) {                 /* MemoryError set */
            PyMem_Free(out);
            PyBuffer_Release(&view);
            return NULL;
        }
        size_t length = strlen(text);
        if (used + length + 1 > cap) {
            size_t larger = cap > (size_t)PY_SSIZE_T_MAX / 2 ? 0 : 2 * cap + length + 1;
            char *grown = larger ? PyMem_Realloc(out, larger) : NULL;
            if (grown == NULL) {
                PyMem_Free(text);
                PyMem_Free(out);
                PyBuffer_Release(&view);
                return PyErr_NoMemory();
            }
            out = grown;
            cap = larger;
        }
        memcpy(out + used, text, length);
        used += length;
        PyMem_Free(text);
        if (++column == columns) {
            out[used++] = '\n';
            column = 0;
        } else {
            out[used++] = ',';
        }
    }
    PyBuffer_Release(&view);
    PyObject *result = PyUnicode_New((Py_ssize_t)used, 127);
    if (result != NULL && used)
        memcpy(PyUnicode_1BYTE_DATA(result), out, used);
    PyMem_Free(out);
    return result;
}

static PyMethodDef methods[] = {
    {"rows", (PyCFunction)py_rows, METH_O,
     "rows(table) -> the CSV rows of a 2-D C-contiguous float64 array, numbers as repr"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, MODULE_NAME, NULL, -1, methods};

PyMODINIT_FUNC INIT_FUNCTION(void) { return PyModule_Create(&module); }
