/* The step every stiff actuator state takes: the exponential Rosenbrock-Euler method.

   For y' = f(t, y) with the Jacobian J = df/dy at the step's start (t0, y0), one step of h is

     y1 = y0 + h phi1(h J) f(t0, y0) + h phi2(h J) (f(t1, y0) - f(t0, y0))

   with phi1(z) = (e^z - 1)/z and phi2(z) = (e^z - 1 - z)/z^2 (Hochbruck, Ostermann and
   Schweitzer, "Exponential Rosenbrock-type methods", SIAM J. Numer. Anal. 47, 2009; the second
   term takes the explicit time dependence, here the piston's motion over the step, to second
   order). Why this scheme for the chambers, the spool and every hydraulic state to come:

   - it is exact for linear dynamics, and the stiff part of a hydraulic state is nearly linear
     over a step (a chamber filling through an open edge is a first-order decay towards the
     pressure where the flows balance; a spool's lag is linear): the step is set by the arm's
     mechanics, never by a filling time constant of microseconds;
   - it is second order for smooth nonlinear f, and stable for any step on decaying modes (the
     decay e^(h lambda) is taken exactly, with no overshoot: L-stable in effect);
   - it needs one Jacobian and one matrix exponential per step, of the few states of one
     actuator (at most ML_STIFF_MAX), with no iteration: a cost fixed in advance, as a real-time
     plant and an FMU need; an implicit Runge-Kutta (Radau) would need Newton iterations, a
     linearly implicit Euler (the Rosenbrock-Euler W-method) is only first order.

   phi1 and phi2 come from one exponential of the augmented (n + 2) x (n + 2) matrix
   [[hJ, h df, h f0], [0, 0, 1], [0, 0, 0]] (Al-Mohy and Higham 2011, theorem 2.1): its last
   column's first n entries are the increment. The exponential is the [6/6] Pade approximant
   with scaling and squaring (Moler and Van Loan's method 3; Higham 2005), on a matrix whose
   states the caller has scaled to like magnitudes. */
#ifndef MANIPLAB_STIFF_H_
#define MANIPLAB_STIFF_H_

#define ML_STIFF_MAX 6 /* the most states one step takes */

/* E = exp(A) for an n x n row-major matrix (n <= ML_STIFF_MAX + 2). Returns 0, or -1 when A
   holds a non-finite number (E is then left NaN). */
int ml_expm(int n, const double* A, double* E);

/* The exponential Rosenbrock-Euler increment dy = y1 - y0 (n), for n <= ML_STIFF_MAX states:
   J the Jacobian at the start (n x n, row-major), f0 = f(t0, y0), df = f(t1, y0) - f(t0, y0)
   (NULL: f does not depend on t), h the step. Returns 0, or -1 (dy NaN) on a non-finite input. */
int ml_exponential_step(int n, double h, const double* J, const double* f0, const double* df,
                        double* dy);

#endif
