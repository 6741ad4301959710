/* Small dense linear algebra for the compiled cascade: the damped least-squares inverse of a task
   Jacobian (maniplab.control.kinematics.DampedLeastSquares) through a one-sided Jacobi SVD.

   x = W sum_i sigma_i / (sigma_i^2 + lambda^2) v_i u_i^T b over the singular values of A = J W
   (W = diag(weights), the joints' weights), with lambda^2 = damping^2 (1 - (sigma_min /
   threshold)^2) when sigma_min < threshold, else 0 (Maciejewski and Klein's singular-region
   damping); undamped, singular values below 1e-12 sigma_max count as zero (the pseudo-inverse).

   One-sided Jacobi (Hestenes) orthogonalises the columns of the taller of A and A^T by plane
   rotations: accurate (each singular value to a few ulps of the largest), short, and fast for the
   at most 6 columns a task Jacobian has. Nothing here allocates: the caller gives the scratch. */
#ifndef MANIPLAB_LINALG_H_
#define MANIPLAB_LINALG_H_

typedef struct {
  int m, n;        /* A is m x n */
  int k;           /* min(m, n): singular values */
  int r;           /* max(m, n): rows of the Jacobi's columns */
  int transposed;  /* 1: the Jacobi runs on A^T (m < n) */
  const double* weights;  /* (n), or NULL for all 1 */
  double* cols;    /* (r, k) column-major: A's (or A^T's) columns, rotated, then normalised */
  double* rot;     /* (k, k) column-major: the accumulated rotations */
  double* sigma;   /* (k) singular values, in no particular order */
  double* gain;    /* (k) sigma / (sigma^2 + lambda^2), or the pseudo-inverse's 1/sigma */
  double* work;    /* (k) */
  double lam2;     /* the damping lambda^2 used */
} ml_dls;

/* Doubles of scratch ml_dls_init needs for an m x n matrix. */
int ml_dls_scratch(int m, int n);

/* Set up for m x n matrices on `scratch` (ml_dls_scratch(m, n) doubles). */
void ml_dls_init(ml_dls* s, int m, int n, double* scratch);

/* Factor J (m x n, row-major) weighted by `weights` (n, or NULL): its SVD, the damping and the
   gains. damping: lambda_max; threshold: sigma below which damping starts (0: never). */
void ml_dls_factor(ml_dls* s, const double* J, const double* weights, double damping,
                   double threshold);

/* x (n x cols, row-major) for J x ~ rhs (m x cols, row-major), after ml_dls_factor (s->work is
   its scratch). */
void ml_dls_solve(ml_dls* s, const double* rhs, int cols, double* x);

#endif
