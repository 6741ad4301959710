/* The exponential Rosenbrock-Euler step (stiff.h). */
#include "stiff.h"

#include <math.h>
#include <string.h>

#define ML_EXPM_MAX (ML_STIFF_MAX + 2)

/* The [6/6] Pade coefficients of exp: c_k = (2q - k)! q! / ((2q)! k! (q - k)!), q = 6. */
static const double kPade[7] = {1.0, 0.5, 5.0 / 44.0, 1.0 / 66.0, 1.0 / 792.0, 1.0 / 15840.0,
                                1.0 / 665280.0};

static void multiply(int n, const double* A, const double* B, double* C) {
  for (int i = 0; i < n; i++) {
    for (int j = 0; j < n; j++) {
      double sum = 0.0;
      for (int k = 0; k < n; k++) sum += A[i * n + k] * B[k * n + j];
      C[i * n + j] = sum;
    }
  }
}

/* X = D^-1 N by Gaussian elimination with partial pivoting (D is overwritten). */
static void solve(int n, double* D, const double* N, double* X) {
  memcpy(X, N, sizeof(double) * n * n);
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
        t = X[c * n + k];
        X[c * n + k] = X[pivot * n + k];
        X[pivot * n + k] = t;
      }
    }
    for (int r = c + 1; r < n; r++) {
      double factor = D[r * n + c] / D[c * n + c];
      if (factor == 0.0) continue;
      for (int k = c; k < n; k++) D[r * n + k] -= factor * D[c * n + k];
      for (int k = 0; k < n; k++) X[r * n + k] -= factor * X[c * n + k];
    }
  }
  for (int c = n - 1; c >= 0; c--) {
    for (int k = 0; k < n; k++) {
      double sum = X[c * n + k];
      for (int j = c + 1; j < n; j++) sum -= D[c * n + j] * X[j * n + k];
      X[c * n + k] = sum / D[c * n + c];
    }
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
  int squarings = 0;
  if (norm > 0.5) squarings = (int)ceil(log2(norm / 0.5));
  double scale = ldexp(1.0, -squarings);
  double X[ML_EXPM_MAX * ML_EXPM_MAX], P[ML_EXPM_MAX * ML_EXPM_MAX], T[ML_EXPM_MAX * ML_EXPM_MAX];
  double N[ML_EXPM_MAX * ML_EXPM_MAX], D[ML_EXPM_MAX * ML_EXPM_MAX];
  for (int k = 0; k < n * n; k++) {
    X[k] = A[k] * scale;
    P[k] = X[k];
    N[k] = kPade[1] * X[k];
    D[k] = -kPade[1] * X[k];
  }
  for (int i = 0; i < n; i++) {
    N[i * n + i] += 1.0;
    D[i * n + i] += 1.0;
  }
  for (int power = 2; power <= 6; power++) {  /* P = X^power */
    multiply(n, P, X, T);
    memcpy(P, T, sizeof(double) * n * n);
    double sign = (power % 2) ? -1.0 : 1.0;
    for (int k = 0; k < n * n; k++) {
      N[k] += kPade[power] * P[k];
      D[k] += sign * kPade[power] * P[k];
    }
  }
  solve(n, D, N, E);
  for (int s = 0; s < squarings; s++) {
    multiply(n, E, E, T);
    memcpy(E, T, sizeof(double) * n * n);
  }
  return 0;
}

int ml_exponential_step(int n, double h, const double* J, const double* f0, const double* df,
                        double* dy) {
  int size = n + 2;
  double M[ML_EXPM_MAX * ML_EXPM_MAX], E[ML_EXPM_MAX * ML_EXPM_MAX];
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
  memset(M, 0, sizeof(M));
  for (int i = 0; i < n; i++) {
    for (int j = 0; j < n; j++) M[i * size + j] = h * J[i * n + j];
    M[i * size + n] = df ? h * df[i] / beta : 0.0;
    M[i * size + n + 1] = h * f0[i] / beta;
  }
  M[n * size + n + 1] = 1.0;
  int status = ml_expm(size, M, E);
  for (int i = 0; i < n; i++) dy[i] = beta * E[i * size + n + 1];
  return status;
}
