/* The exponential Rosenbrock-Euler step (stiff.h). */
#include "stiff.h"

#include <math.h>
#include <string.h>

#define ML_EXPM_MAX (ML_STIFF_MAX + 2)

/* The [6/6] Pade coefficients of exp: c_k = (2q - k)! q! / ((2q)! k! (q - k)!), q = 6. */
static const double kPade[7] = {1.0, 0.5, 5.0 / 44.0, 1.0 / 66.0, 1.0 / 792.0, 1.0 / 15840.0,
                                1.0 / 665280.0};

/* The largest 1-norm the approximant takes unscaled: its truncation error there is about
   (6!)^2 / (12! 13!) = 1.7e-13 relative, near double precision (Higham 2005 uses 0.54 for this
   degree to reach the unit roundoff itself; a step needs far less). */
static const double kTheta = 1.0;

#define ML_INLINE static inline __attribute__((always_inline))

ML_INLINE void multiply(int n, const double* A, const double* B, double* C) {
  for (int i = 0; i < n; i++) {
    for (int j = 0; j < n; j++) {
      double sum = 0.0;
      for (int k = 0; k < n; k++) sum += A[i * n + k] * B[k * n + j];
      C[i * n + j] = sum;
    }
  }
}

/* X = D^-1 N by Gaussian elimination with partial pivoting, for D n x n and N, X n x m
   (row-major; D is overwritten). */
ML_INLINE void solve_columns(int n, int m, double* D, const double* N, double* X) {
  memcpy(X, N, sizeof(double) * n * m);
  for (int c = 0; c < n; c++) {
    int pivot = c;
    for (int r = c + 1; r < n; r++) {
      if (fabs(D[r * n + c]) > fabs(D[pivot * n + c])) pivot = r;
    }
    if (pivot != c) {
      for (int k = 0; k < n; k++) {
        double t = D[c * n + k];
        D[c * n + k] = D[pivot * n + k];
        D[pivot * n + k] = t;
      }
      for (int k = 0; k < m; k++) {
        double t = X[c * m + k];
        X[c * m + k] = X[pivot * m + k];
        X[pivot * m + k] = t;
      }
    }
    for (int r = c + 1; r < n; r++) {
      double factor = D[r * n + c] / D[c * n + c];
      if (factor == 0.0) continue;
      for (int k = c; k < n; k++) D[r * n + k] -= factor * D[c * n + k];
      for (int k = 0; k < m; k++) X[r * m + k] -= factor * X[c * m + k];
    }
  }
  for (int c = n - 1; c >= 0; c--) {
    for (int k = 0; k < m; k++) {
      double sum = X[c * m + k];
      for (int j = c + 1; j < n; j++) sum -= D[c * n + j] * X[j * m + k];
      X[c * m + k] = sum / D[c * n + c];
    }
  }
}

/* The squarings that bring a matrix of 1-norm `norm` within kTheta. */
static int squarings_for(double norm) {
  return norm > kTheta ? (int)ceil(log2(norm / kTheta)) : 0;
}

/* The Pade sums' first terms of `count` entries of X = A scale: P = X, N = c1 X, D = -c1 X (the
   identity is the caller's to add). */
ML_INLINE void pade_begin(int count, const double* A, double scale, double* X, double* P,
                          double* N, double* D) {
  for (int k = 0; k < count; k++) {
    X[k] = A[k] * scale;
    P[k] = X[k];
    N[k] = kPade[1] * X[k];
    D[k] = -kPade[1] * X[k];
  }
}

/* The Pade sums' term of `power` from `count` entries of P = X^power: N += c P, D += (-1)^p c P. */
ML_INLINE void pade_add(int count, int power, const double* P, double* N, double* D) {
  double sign = (power % 2) ? -1.0 : 1.0;
  for (int k = 0; k < count; k++) {
    N[k] += kPade[power] * P[k];
    D[k] += sign * kPade[power] * P[k];
  }
}

int ml_expm(int n, const double* A, double* E) {
  double norm = 0.0;  /* the 1-norm: the largest column sum */
  for (int j = 0; j < n; j++) {
    double sum = 0.0;
    for (int i = 0; i < n; i++) sum += fabs(A[i * n + j]);
    if (!isfinite(sum)) {
      for (int k = 0; k < n * n; k++) E[k] = NAN;
      return -1;
    }
    norm = sum > norm ? sum : norm;
  }
  int squarings = squarings_for(norm);
  double scale = ldexp(1.0, -squarings);
  double X[ML_EXPM_MAX * ML_EXPM_MAX], P[ML_EXPM_MAX * ML_EXPM_MAX], T[ML_EXPM_MAX * ML_EXPM_MAX];
  double N[ML_EXPM_MAX * ML_EXPM_MAX], D[ML_EXPM_MAX * ML_EXPM_MAX];
  pade_begin(n * n, A, scale, X, P, N, D);
  for (int i = 0; i < n; i++) {
    N[i * n + i] += 1.0;
    D[i * n + i] += 1.0;
  }
  for (int power = 2; power <= 6; power++) {  /* P = X^power */
    multiply(n, P, X, T);
    memcpy(P, T, sizeof(double) * n * n);
    pade_add(n * n, power, P, N, D);
  }
  solve_columns(n, n, D, N, E);
  for (int s = 0; s < squarings; s++) {
    multiply(n, E, E, T);
    memcpy(E, T, sizeof(double) * n * n);
  }
  return 0;
}

/* exp of the augmented matrix M = [[A, B], [0, N]] (A n x n, B n x 2, N = [[0, 1], [0, 0]],
   all row-major) by the same Pade approximant and squaring as ml_expm, on its blocks: the lower
   right block of every power of N is known (N^2 = 0) and the lower left is zero, so only A's
   powers and the n x 2 upper right block are formed, about half the work of the whole matrix.
   Returns the upper right block of exp(M) in E12 (n x 2). */
ML_INLINE void augmented_expm(int n, const double* A, const double* B, double norm, double* E12) {
  int squarings = squarings_for(norm);
  double scale = ldexp(1.0, -squarings), nu = scale; /* the scaled N's entry */
  double X[ML_STIFF_MAX * ML_STIFF_MAX], P11[ML_STIFF_MAX * ML_STIFF_MAX];
  double T11[ML_STIFF_MAX * ML_STIFF_MAX], N11[ML_STIFF_MAX * ML_STIFF_MAX];
  double D11[ML_STIFF_MAX * ML_STIFF_MAX], E11[ML_STIFF_MAX * ML_STIFF_MAX];
  double X12[ML_STIFF_MAX * 2], P12[ML_STIFF_MAX * 2], T12[ML_STIFF_MAX * 2];
  double N12[ML_STIFF_MAX * 2], D12[ML_STIFF_MAX * 2];
  pade_begin(n * n, A, scale, X, P11, N11, D11);
  pade_begin(2 * n, B, scale, X12, P12, N12, D12);
  for (int i = 0; i < n; i++) {
    N11[i * n + i] += 1.0;
    D11[i * n + i] += 1.0;
  }
  for (int power = 2; power <= 6; power++) { /* P = P X: P12 = P11 X12 + P12 X22 */
    for (int i = 0; i < n; i++) {
      double a = 0.0, b = nu * P12[2 * i];
      for (int k = 0; k < n; k++) {
        a += P11[i * n + k] * X12[2 * k];
        b += P11[i * n + k] * X12[2 * k + 1];
      }
      T12[2 * i] = a;
      T12[2 * i + 1] = b;
    }
    multiply(n, P11, X, T11);
    memcpy(P11, T11, sizeof(double) * n * n);
    memcpy(P12, T12, sizeof(double) * 2 * n);
    pade_add(n * n, power, P11, N11, D11);
    pade_add(2 * n, power, P12, N12, D12);
  }
  /* D R = N: R22 = [[1, nu], [0, 1]] (exact: c1 = 1/2), R11 = D11^-1 N11,
     R12 = D11^-1 (N12 - D12 R22) */
  double rhs[ML_STIFF_MAX * (ML_STIFF_MAX + 2)], R[ML_STIFF_MAX * (ML_STIFF_MAX + 2)];
  int width = n + 2;
  for (int i = 0; i < n; i++) {
    for (int j = 0; j < n; j++) rhs[i * width + j] = N11[i * n + j];
    rhs[i * width + n] = N12[2 * i] - D12[2 * i];
    rhs[i * width + n + 1] = N12[2 * i + 1] - nu * D12[2 * i] - D12[2 * i + 1];
  }
  solve_columns(n, width, D11, rhs, R);
  for (int i = 0; i < n; i++) {
    for (int j = 0; j < n; j++) E11[i * n + j] = R[i * width + j];
    E12[2 * i] = R[i * width + n];
    E12[2 * i + 1] = R[i * width + n + 1];
  }
  for (int s = 0; s < squarings; s++) { /* E^2: E12 = E11 E12 + E12 E22, E22 = [[1, nu], [0, 1]] */
    for (int i = 0; i < n; i++) {
      double a = E12[2 * i], b = nu * E12[2 * i] + E12[2 * i + 1];
      for (int k = 0; k < n; k++) {
        a += E11[i * n + k] * E12[2 * k];
        b += E11[i * n + k] * E12[2 * k + 1];
      }
      T12[2 * i] = a;
      T12[2 * i + 1] = b;
    }
    memcpy(E12, T12, sizeof(double) * 2 * n);
    nu *= 2.0;
    if (s + 1 < squarings) { /* the last square's E11 is not needed */
      multiply(n, E11, E11, T11);
      memcpy(E11, T11, sizeof(double) * n * n);
    }
  }
}

int ml_exponential_step(int n, double h, const double* J, const double* f0, const double* df,
                        double* dy) {
  double A[ML_STIFF_MAX * ML_STIFF_MAX], B[ML_STIFF_MAX * 2], E12[ML_STIFF_MAX * 2];
  /* the forcing columns are linear in the result: bring them to the size of 1 */
  double beta = 0.0;
  for (int i = 0; i < n; i++) {
    beta = fmax(beta, fabs(f0[i]));
    if (df) beta = fmax(beta, fabs(df[i]));
  }
  beta *= h;
  if (!isfinite(beta)) {
    for (int i = 0; i < n; i++) dy[i] = NAN;
    return -1;
  }
  if (beta == 0.0) {
    for (int i = 0; i < n; i++) dy[i] = 0.0;
    return 0;
  }
  double norm = 0.0, last = 1.0, before = 0.0; /* the 1-norm of the augmented matrix */
  for (int i = 0; i < n; i++) {
    for (int j = 0; j < n; j++) A[i * n + j] = h * J[i * n + j];
    B[2 * i] = df ? h * df[i] / beta : 0.0;
    B[2 * i + 1] = h * f0[i] / beta;
    before += fabs(B[2 * i]);
    last += fabs(B[2 * i + 1]);
  }
  for (int j = 0; j < n; j++) {
    double sum = 0.0;
    for (int i = 0; i < n; i++) sum += fabs(A[i * n + j]);
    if (!isfinite(sum)) {
      for (int i = 0; i < n; i++) dy[i] = NAN;
      return -1;
    }
    norm = fmax(norm, sum);
  }
  norm = fmax(norm, fmax(before, last));
  if (n == 3) { /* the chambers' (pA, pB, spool): a copy the compiler unrolls */
    augmented_expm(3, A, B, norm, E12);
  } else {
    augmented_expm(n, A, B, norm, E12);
  }
  for (int i = 0; i < n; i++) dy[i] = beta * E12[2 * i + 1];
  return 0;
}
