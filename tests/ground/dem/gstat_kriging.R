# Ordinary kriging with R's gstat (Debian r-cran-gstat) of the points that ground_products_bench --export
# wrote, with OUR fitted variogram model and the same neighbourhood size (nmax = k), onto the same grid;
# prints the time and the RMSE against the same synthetic field. Called by gstat_benchmark.sh.
suppressPackageStartupMessages({ library(sp); library(gstat) })
args <- commandArgs(trailingOnly = TRUE)
stem <- args[1]
pts <- read.csv(paste0(stem, ".csv"))
m <- read.csv(paste0(stem, "_model.csv"))
field <- function(x, y) 0.4 * sin(x / 7) * cos(y / 11) + 0.2 * sin((x + y) / 5) + 0.05 * cos(x / 2.3)
# areomap's range is the practical range; gstat's Exp / Gau range parameter a has it at 3a / sqrt(3) a.
kind <- switch(as.character(m$kind), spherical = "Sph", exponential = "Exp", gaussian = "Gau")
a <- switch(kind, Sph = m$range_m, Exp = m$range_m / 3, Gau = m$range_m / sqrt(3))
model <- vgm(psill = m$partial_sill_m2, model = kind, range = a, nugget = m$nugget_m2)
side <- m$side
cell <- 100 / side
grid <- expand.grid(east = (0:(side - 1) + 0.5) * cell, north = 100 - (0:(side - 1) + 0.5) * cell)
coordinates(pts) <- ~east + north
coordinates(grid) <- ~east + north
t0 <- proc.time()[["elapsed"]]
k <- krige(z ~ 1, pts, grid, model = model, nmax = m$k, debug.level = 0)
t <- proc.time()[["elapsed"]] - t0
cc <- coordinates(grid)
# The field's x is north, y is east (as in the benchmark).
rmse <- sqrt(mean((k$var1.pred - field(cc[, "north"], cc[, "east"]))^2))
cat(sprintf("| %d | %d x %d | %d | %s | gstat %.2f s | areomap %.2f s (%d threads) | %.1f x | areomap %.2f s (1 thread) | %.1f x | gstat %.4f m | areomap %.4f m |\n",
            length(pts), side, side, m$k, m$kind, t, m$areomap_kriging_s, m$areomap_threads,
            t / m$areomap_kriging_s, m$areomap_kriging_1thread_s, t / m$areomap_kriging_1thread_s, rmse,
            m$areomap_rmse_m))
