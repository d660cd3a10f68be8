#include "system/serial_vector_ops.h"

#include <cmath>

namespace rectify::system
{
  namespace
  {
    sunindextype length(N_Vector v) { return NV_LENGTH_S(v); }
    double      *data(N_Vector v) { return NV_DATA_S(v); }

    /// z = a x + b y with the library's special cases, each of which it
    /// computes in its own way: y += a x, x += b y, x + y, x - y, a x + y,
    /// a x - y, a (x + y), a (x - y), else a x + b y.
    void linear_sum(double a, N_Vector x, double b, N_Vector y, N_Vector z)
    {
      const sunindextype n = length(x);
      if ((b == 1.0 && z == y) || (a == 1.0 && z == x))
        { // axpy in place: y <- a x + y (or x <- b y + x)
          const bool   into_y = b == 1.0 && z == y;
          const double c      = into_y ? a : b;
          const double *in    = data(into_y ? x : y);
          double       *out   = data(into_y ? y : x);
          if (c == 1.0)
            for (sunindextype i = 0; i < n; ++i)
              out[i] += in[i];
          else if (c == -1.0)
            for (sunindextype i = 0; i < n; ++i)
              out[i] -= in[i];
          else
            for (sunindextype i = 0; i < n; ++i)
              out[i] += c * in[i];
          return;
        }
      const double *xd = data(x), *yd = data(y);
      double       *zd = data(z);
      if (a == 1.0 && b == 1.0)
        {
          for (sunindextype i = 0; i < n; ++i)
            zd[i] = xd[i] + yd[i];
          return;
        }
      if ((a == 1.0 && b == -1.0) || (a == -1.0 && b == 1.0))
        { // the positive one minus the negative one
          const double *p = a == 1.0 ? xd : yd, *m = a == 1.0 ? yd : xd;
          for (sunindextype i = 0; i < n; ++i)
            zd[i] = p[i] - m[i];
          return;
        }
      if (a == 1.0 || b == 1.0)
        { // c v + w, w the one with coefficient 1
          const bool    first = a == 1.0;
          const double  c     = first ? b : a;
          const double *v = first ? yd : xd, *w = first ? xd : yd;
          for (sunindextype i = 0; i < n; ++i)
            zd[i] = (c * v[i]) + w[i];
          return;
        }
      if (a == -1.0 || b == -1.0)
        { // c v - w, w the one with coefficient -1
          const bool    first = a == -1.0;
          const double  c     = first ? b : a;
          const double *v = first ? yd : xd, *w = first ? xd : yd;
          for (sunindextype i = 0; i < n; ++i)
            zd[i] = (c * v[i]) - w[i];
          return;
        }
      if (a == b)
        {
          for (sunindextype i = 0; i < n; ++i)
            zd[i] = a * (xd[i] + yd[i]);
          return;
        }
      if (a == -b)
        {
          for (sunindextype i = 0; i < n; ++i)
            zd[i] = a * (xd[i] - yd[i]);
          return;
        }
      for (sunindextype i = 0; i < n; ++i)
        zd[i] = (a * xd[i]) + (b * yd[i]);
    }

    void constant(double c, N_Vector z)
    {
      double *zd = data(z);
      for (sunindextype i = 0, n = length(z); i < n; ++i)
        zd[i] = c;
    }

    void product(N_Vector x, N_Vector y, N_Vector z)
    {
      const double *xd = data(x), *yd = data(y);
      double       *zd = data(z);
      for (sunindextype i = 0, n = length(x); i < n; ++i)
        zd[i] = xd[i] * yd[i];
    }

    void quotient(N_Vector x, N_Vector y, N_Vector z)
    {
      const double *xd = data(x), *yd = data(y);
      double       *zd = data(z);
      for (sunindextype i = 0, n = length(x); i < n; ++i)
        zd[i] = xd[i] / yd[i];
    }

    void scale(double c, N_Vector x, N_Vector z)
    {
      const sunindextype n  = length(x);
      double            *zd = data(z);
      if (z == x)
        {
          for (sunindextype i = 0; i < n; ++i)
            zd[i] *= c;
          return;
        }
      const double *xd = data(x);
      if (c == 1.0)
        for (sunindextype i = 0; i < n; ++i)
          zd[i] = xd[i];
      else if (c == -1.0)
        for (sunindextype i = 0; i < n; ++i)
          zd[i] = -xd[i];
      else
        for (sunindextype i = 0; i < n; ++i)
          zd[i] = c * xd[i];
    }

    void absolute(N_Vector x, N_Vector z)
    {
      const double *xd = data(x);
      double       *zd = data(z);
      for (sunindextype i = 0, n = length(x); i < n; ++i)
        zd[i] = std::abs(xd[i]);
    }

    void inverse(N_Vector x, N_Vector z)
    {
      const double *xd = data(x);
      double       *zd = data(z);
      for (sunindextype i = 0, n = length(x); i < n; ++i)
        zd[i] = 1.0 / xd[i];
    }

    void add_constant(N_Vector x, double b, N_Vector z)
    {
      const double *xd = data(x);
      double       *zd = data(z);
      for (sunindextype i = 0, n = length(x); i < n; ++i)
        zd[i] = xd[i] + b;
    }

    double dot(N_Vector x, N_Vector y)
    {
      const double *xd = data(x), *yd = data(y);
      double        sum = 0.0;
      for (sunindextype i = 0, n = length(x); i < n; ++i)
        sum += xd[i] * yd[i];
      return sum;
    }

    double max_norm(N_Vector x)
    {
      const double *xd  = data(x);
      double        max = 0.0;
      for (sunindextype i = 0, n = length(x); i < n; ++i)
        if (std::abs(xd[i]) > max)
          max = std::abs(xd[i]);
      return max;
    }

    double weighted_square_sum(N_Vector x, N_Vector w)
    {
      const double *xd = data(x), *wd = data(w);
      double        sum = 0.0;
      for (sunindextype i = 0, n = length(x); i < n; ++i)
        {
          const double p = xd[i] * wd[i];
          sum += p * p;
        }
      return sum;
    }

    double weighted_rms_norm(N_Vector x, N_Vector w)
    {
      const double s = weighted_square_sum(x, w) / static_cast<double>(length(x));
      return s <= 0.0 ? 0.0 : std::sqrt(s); // SUNRsqrt
    }

    double minimum(N_Vector x)
    {
      const double *xd  = data(x);
      double        min = xd[0];
      for (sunindextype i = 1, n = length(x); i < n; ++i)
        if (xd[i] < min)
          min = xd[i];
      return min;
    }
  } // namespace

  void use_optimised_serial_ops(N_Vector v)
  {
    v->ops->nvlinearsum    = linear_sum;
    v->ops->nvconst        = constant;
    v->ops->nvprod         = product;
    v->ops->nvdiv          = quotient;
    v->ops->nvscale        = scale;
    v->ops->nvabs          = absolute;
    v->ops->nvinv          = inverse;
    v->ops->nvaddconst     = add_constant;
    v->ops->nvdotprod      = dot;
    v->ops->nvmaxnorm      = max_norm;
    v->ops->nvwrmsnorm     = weighted_rms_norm;
    v->ops->nvmin          = minimum;
    v->ops->nvdotprodlocal = dot;
    v->ops->nvmaxnormlocal = max_norm;
    v->ops->nvminlocal     = minimum;
    v->ops->nvwsqrsumlocal = weighted_square_sum;
  }
} // namespace rectify::system
