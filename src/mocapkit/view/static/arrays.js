// The scene's numeric arrays: {"dtype", "shape", "b64"} -> a typed array over the decoded bytes.

const TYPES = { float32: Float32Array, float64: Float64Array };

/**
 * Decode one array object of the scene.
 * @param {{dtype: string, shape: number[], b64: string}|null} obj
 * @param {string} where  what the array is, for the error message
 * @returns {{data: Float32Array|Float64Array, shape: number[]}|null}  null for a null input
 */
export function decodeArray(obj, where) {
  if (obj === null || obj === undefined) return null;
  const Type = TYPES[obj.dtype];
  if (!Type || !Array.isArray(obj.shape) || typeof obj.b64 !== "string") {
    throw new Error(`${where}: not an array object`);
  }
  const text = atob(obj.b64);
  const count = obj.shape.reduce((a, b) => a * b, 1);
  if (text.length !== count * Type.BYTES_PER_ELEMENT) {
    throw new Error(`${where}: ${text.length} bytes do not hold a ${obj.dtype} array of shape [${obj.shape}]`);
  }
  const bytes = new Uint8Array(text.length);
  for (let i = 0; i < text.length; i++) bytes[i] = text.charCodeAt(i);
  // The bytes are little-endian, as every browser platform is; DataView would be needed otherwise.
  return { data: new Type(bytes.buffer), shape: obj.shape.slice() };
}

/**
 * Index of the last value of the increasing array `times` at or before `t` (0 when `t` is before the first).
 * @param {Float64Array|number[]} times
 * @param {number} t
 */
export function sampleAt(times, t) {
  let lo = 0;
  let hi = times.length - 1;
  if (hi < 0 || t <= times[0]) return 0;
  if (t >= times[hi]) return hi;
  while (hi - lo > 1) {
    const mid = (lo + hi) >> 1;
    if (times[mid] <= t) lo = mid;
    else hi = mid;
  }
  return lo;
}

/** Index of the value of the increasing array `times` nearest to `t`. */
export function nearestSample(times, t) {
  const i = sampleAt(times, t);
  if (i + 1 < times.length && Math.abs(times[i + 1] - t) < Math.abs(t - times[i])) return i + 1;
  return i;
}
