//! `RayScene`: antumbra-rays' [`Scene`] over numpy arrays, the native half of `antumbra.rays`
//! (whose Python classes, the embreex-like `Scene` and trimesh's `RayMeshIntersector`, check
//! and convert the caller's arrays before they get here). Traversal runs without the GIL.

use antumbra_rays::{
    BoxKernel, BuildMethod, BuildOptions, BvhWidth, CollapseMethod, CollapseSettings, Interval,
    Ray, Scene, ShadowOrder, TraceOptions, TraversalStats, MAX_THREADS,
};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::error::{ClientError, ClientResult, IntoPyResult};

/// A BVH over triangles given as numpy arrays, with any-hit and closest-hit queries.
#[pyclass(frozen, module = "antumbra._native")]
pub struct RayScene {
    scene: Scene,
}

/// The rows of a C-contiguous (n, 3) array, or an error naming `field`.
fn rows<'a, T: numpy::Element>(
    array: &'a PyReadonlyArray2<'_, T>,
    field: &str,
) -> ClientResult<&'a [[T; 3]]> {
    let shape = array.shape();
    if shape.len() != 2 || shape[1] != 3 {
        return Err(ClientError::invalid(format!(
            "{field}: expected shape (n, 3), got {shape:?}"
        )));
    }
    let flat = array
        .as_slice()
        .map_err(|_| ClientError::invalid(format!("{field}: not a C-contiguous array")))?;
    let (chunks, rest) = flat.as_chunks::<3>();
    debug_assert!(rest.is_empty());
    Ok(chunks)
}

fn invalid(e: antumbra_rays::Error) -> ClientError {
    ClientError::invalid(e.to_string())
}

fn parse<T: std::str::FromStr<Err = antumbra_rays::Error>>(text: &str) -> ClientResult<T> {
    text.parse().map_err(invalid)
}

/// The builder named by the `method` keyword, its errors named after the keyword.
fn build_method(text: &str) -> ClientResult<BuildMethod> {
    text.parse::<BuildMethod>().map_err(|e| match e {
        antumbra_rays::Error::Invalid { message, .. } => {
            ClientError::invalid(format!("method: {message}"))
        }
        e => invalid(e),
    })
}

fn kernel(name: &str) -> ClientResult<BoxKernel> {
    Ok(match name {
        "auto" => BoxKernel::Auto,
        "scalar" => BoxKernel::Scalar,
        "sse" => BoxKernel::Sse,
        "avx2" => BoxKernel::Avx2,
        other => {
            return Err(ClientError::invalid(format!(
                "kernel: unknown box kernel '{other}' (known: auto, scalar, sse, avx2)"
            )))
        }
    })
}

/// The batch's rays from origins, directions and per-ray t bounds (all of n rows).
fn batch(
    origins: &PyReadonlyArray2<'_, f64>,
    directions: &PyReadonlyArray2<'_, f64>,
    t_near: &PyReadonlyArray1<'_, f32>,
    t_far: &PyReadonlyArray1<'_, f32>,
) -> ClientResult<Vec<Ray>> {
    let o = rows(origins, "origins")?;
    let d = rows(directions, "directions")?;
    let near = t_near
        .as_slice()
        .map_err(|_| ClientError::invalid("t_near: not contiguous"))?;
    let far = t_far
        .as_slice()
        .map_err(|_| ClientError::invalid("t_far: not contiguous"))?;
    if d.len() != o.len() || near.len() != o.len() || far.len() != o.len() {
        return Err(ClientError::invalid(format!(
            "origins ({}), directions ({}), t_near ({}) and t_far ({}) must have as many rows",
            o.len(),
            d.len(),
            near.len(),
            far.len()
        )));
    }
    Ok((0..o.len())
        .map(|i| Ray::segment(o[i], d[i], near[i], far[i]))
        .collect())
}

/// The `threads` keyword as a count. Taken signed, so that a negative count is refused here with
/// the limit, as antumbra-rays refuses one above it, instead of Python's OverflowError.
fn thread_count(value: i64) -> ClientResult<usize> {
    usize::try_from(value).map_err(|_| {
        ClientError::invalid(format!(
            "threads: must be in 0..={MAX_THREADS}, got {value}"
        ))
    })
}

fn trace_options(
    closed: bool,
    order: &str,
    kernel_name: &str,
    threads: i64,
) -> ClientResult<TraceOptions> {
    Ok(TraceOptions {
        interval: if closed {
            Interval::Closed
        } else {
            Interval::OpenClosed
        },
        kernel: kernel(kernel_name)?,
        order: parse::<ShadowOrder>(order)?,
        threads: thread_count(threads)?,
    })
}

/// Per-ray work as an (n, 4) uint64 array: N_B, N_L, N_T, N_box.
fn work_array<'py>(py: Python<'py>, work: &[TraversalStats]) -> Bound<'py, PyArray2<u64>> {
    let flat: Vec<u64> = work
        .iter()
        .flat_map(|w| [w.inner, w.leaves, w.triangles, w.boxes])
        .collect();
    Array2::from_shape_vec((work.len(), 4), flat)
        .expect("four counts per ray")
        .into_pyarray(py)
}

#[pymethods]
impl RayScene {
    #[new]
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (vertices, triangles, method = "sah", width = 8, collapse = "sah", threads = 0, visible = None))]
    fn new(
        py: Python<'_>,
        vertices: PyReadonlyArray2<'_, f64>,
        triangles: PyReadonlyArray2<'_, u32>,
        method: &str,
        width: u32,
        collapse: &str,
        threads: i64,
        visible: Option<PyReadonlyArray1<'_, bool>>,
    ) -> PyResult<Self> {
        let build = || -> ClientResult<Scene> {
            let options = BuildOptions {
                method: build_method(method)?,
                width: BvhWidth::try_from(width).map_err(invalid)?,
                collapse: CollapseSettings::new(parse::<CollapseMethod>(collapse)?),
                visible: match &visible {
                    Some(v) => Some(
                        v.as_slice()
                            .map_err(|_| ClientError::invalid("visible: not contiguous"))?
                            .to_vec(),
                    ),
                    None => None,
                },
                threads: thread_count(threads)?,
                ..BuildOptions::default()
            };
            let v = rows(&vertices, "vertices")?;
            let t = rows(&triangles, "triangles")?;
            py.detach(|| Scene::build(v, t, &options)).map_err(invalid)
        };
        Ok(RayScene {
            scene: build().py_result(py)?,
        })
    }

    /// Closest hits: a dict of `t` (float32), `triangle` (int64, -1 for a miss), `u`, `v`
    /// (float32), and `work` ((n, 4) uint64) when `counters`.
    #[pyo3(signature = (origins, directions, t_near, t_far, closed = false, kernel = "auto", threads = 0, counters = false))]
    #[allow(clippy::too_many_arguments)]
    fn intersect<'py>(
        &self,
        py: Python<'py>,
        origins: PyReadonlyArray2<'py, f64>,
        directions: PyReadonlyArray2<'py, f64>,
        t_near: PyReadonlyArray1<'py, f32>,
        t_far: PyReadonlyArray1<'py, f32>,
        closed: bool,
        kernel: &str,
        threads: i64,
        counters: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let run = || -> ClientResult<_> {
            let rays = batch(&origins, &directions, &t_near, &t_far)?;
            let options = trace_options(closed, "fbto", kernel, threads)?;
            py.detach(|| {
                if counters {
                    self.scene.intersect_counted(&rays, &options)
                } else {
                    self.scene
                        .intersect(&rays, &options)
                        .map(|h| (h, Vec::new()))
                }
            })
            .map_err(invalid)
        };
        let (hits, work) = run().py_result(py)?;
        let n = hits.len();
        let (mut t, mut triangle, mut u, mut v) = (
            vec![f32::INFINITY; n],
            vec![-1i64; n],
            vec![0f32; n],
            vec![0f32; n],
        );
        for (i, h) in hits.iter().enumerate() {
            if let Some(h) = h {
                (t[i], triangle[i], u[i], v[i]) = (h.t, h.triangle as i64, h.u, h.v);
            }
        }
        let out = PyDict::new(py);
        out.set_item("t", t.into_pyarray(py))?;
        out.set_item("triangle", triangle.into_pyarray(py))?;
        out.set_item("u", u.into_pyarray(py))?;
        out.set_item("v", v.into_pyarray(py))?;
        if counters {
            out.set_item("work", work_array(py, &work))?;
        }
        Ok(out)
    }

    /// Any hit: a dict of `occluded` (bool), and `work` ((n, 4) uint64) when `counters`.
    #[pyo3(signature = (origins, directions, t_near, t_far, closed = false, order = "fbto", kernel = "auto", threads = 0, counters = false))]
    #[allow(clippy::too_many_arguments)]
    fn occluded<'py>(
        &self,
        py: Python<'py>,
        origins: PyReadonlyArray2<'py, f64>,
        directions: PyReadonlyArray2<'py, f64>,
        t_near: PyReadonlyArray1<'py, f32>,
        t_far: PyReadonlyArray1<'py, f32>,
        closed: bool,
        order: &str,
        kernel: &str,
        threads: i64,
        counters: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let run = || -> ClientResult<_> {
            let rays = batch(&origins, &directions, &t_near, &t_far)?;
            let options = trace_options(closed, order, kernel, threads)?;
            py.detach(|| {
                if counters {
                    self.scene.occluded_counted(&rays, &options)
                } else {
                    self.scene
                        .occluded(&rays, &options)
                        .map(|b| (b, Vec::new()))
                }
            })
            .map_err(invalid)
        };
        let (blocked, work) = run().py_result(py)?;
        let out = PyDict::new(py);
        out.set_item("occluded", blocked.into_pyarray(py))?;
        if counters {
            out.set_item("work", work_array(py, &work))?;
        }
        Ok(out)
    }

    /// Triangles given to the build.
    #[getter]
    fn triangle_count(&self) -> usize {
        self.scene.triangle_count()
    }

    /// Triangles left out for their zero area (they can never be hit).
    #[getter]
    fn degenerate_count(&self) -> usize {
        self.scene.degenerate_count()
    }

    #[getter]
    fn width(&self) -> u32 {
        self.scene.width().get()
    }
}
