# Figures of docs/chapter5-comparison.md, from the outputs of scripts/reference.sh.
# Run from the repository root:  gnuplot docs/figures/chapter5.gp
psi = 6894.757
ref = 'runs/reference/'
set datafile separator ','
set grid
set key top right
set terminal pngcairo size 900,420 noenhanced font ',10'

set output 'docs/figures/no-flow-traces.png'
set title 'No-flow outlet pressure p_o, 20 A p-p / 10 A bias (cf. thesis Figs. 5.1, 5.2)'
set xlabel 'pumping cycles (t f)'
set ylabel 'p_o [psi above bias]'
plot for [f in '5 10 25 50'] ref.'no-flow/trace-'.f.'Hz/timeseries.csv' every ::1 \
     using ($1*f):($13/psi) with lines lw 1.5 title f.' Hz'

set output 'docs/figures/stored-pressure.png'
set title 'No-flow stored pressure (eq. 5.1), 4 A p-p / 2 A bias (cf. thesis Fig. 5.3)'
set xlabel 'pumping frequency [Hz]'
set ylabel 'stored pressure [psi above bias]'
set logscale x
set yrange [-50:300]
$thesis << EOD
1,200
20,200
30,50
1200,50
EOD
plot ref.'no-flow/stored-pressure/sweep.csv' every ::1 using 1:($2/psi) with linespoints pt 7 ps 0.6 title 'rectify, dynamic valves, thesis R(x)', \
     ref.'fe-maps/no-flow/stored-pressure/sweep.csv' every ::1 using 1:($2/psi) with linespoints pt 5 ps 0.6 title 'rectify, dynamic valves, FE maps', \
     ref.'no-flow/stored-pressure/sweep.csv' every ::1 using 1:($3/psi) with linespoints pt 6 ps 0.6 title 'rectify, ideal valves', \
     $thesis using 1:2 with lines dt 2 lw 2 lc rgb 'black' title 'thesis data as its text describes it (approximate)'
unset logscale x
set yrange [*:*]

set output 'docs/figures/velocity.png'
set title 'Mean actuator velocity (eq. 5.2), 50 lb, 20 A p-p / 10 A bias (cf. thesis Figs. 5.4, 5.6)'
set xlabel 'pumping frequency [Hz]'
set ylabel 'mean velocity [m/s]'
set key top left
plot ref.'loaded/velocity/sweep.csv' every ::1 using 1:2 with linespoints pt 7 ps 0.5 title 'dynamic valves, thesis R(x)', \
     ref.'fe-maps/loaded/velocity/sweep.csv' every ::1 using 1:2 with linespoints pt 5 ps 0.5 title 'dynamic valves, FE maps', \
     ref.'loaded/velocity/sweep.csv' every ::1 using 1:3 with linespoints pt 6 ps 0.5 title 'ideal valves', \
     ref.'loaded/velocity/sweep.csv' every ::1 using 1:4 with linespoints pt 4 ps 0.5 title 'reed what-if: 3 k_r, 0.5 m_r, thesis R(x)', \
     ref.'fe-maps/loaded/velocity/sweep.csv' every ::1 using 1:4 with lines lw 2 dt 2 lc rgb 'dark-red' title 'reed what-if, FE maps', \
     0 with lines lc rgb 'black' notitle

# Fig. 5.5: the last two cycles at 1420 Hz, each signal scaled by its largest magnitude there.
f = 1420.0
csv = ref.'loaded/trace-1420Hz/timeseries.csv'
stats csv every ::1 using 1 nooutput
t_end = STATS_max
t0 = t_end - 2.0 / f
stats csv every ::1 using ($1 >= t0 ? abs($17) : 0) nooutput name 'QPI'
stats csv every ::1 using ($1 >= t0 ? abs($15) : 0) nooutput name 'QO'
stats csv every ::1 using ($1 >= t0 ? abs($7) : 0) nooutput name 'XO'
stats csv every ::1 using ($1 >= t0 ? log10($18) : 0) nooutput name 'RO'
set output 'docs/figures/phase-1420Hz.png'
set title 'Loaded, 1420 Hz: normalised signals over the last two cycles (cf. thesis Fig. 5.5)'
set xlabel 'pumping cycle'
set ylabel 'normalised'
set key outside right top
set xrange [0:2]
plot csv every ::1 using (($1 - t0) * f):($1 >= t0 ? $17 / QPI_max : NaN) with lines lw 2 title 'piston flow A_pi dx_p/dt', \
     '' every ::1 using (($1 - t0) * f):($1 >= t0 ? $15 / QO_max : NaN) with lines lw 1.5 title 'outlet valve flow', \
     '' every ::1 using (($1 - t0) * f):($1 >= t0 ? $7 / XO_max : NaN) with lines lw 1.5 title 'outlet reed opening', \
     '' every ::1 using (($1 - t0) * f):($1 >= t0 ? log10($18) / RO_max : NaN) with lines dt 2 title 'log10 R1 (scaled)'
