# The scaling plot of docs/benchmarks.md from docs/bench/scaling.dat (gnuplot docs/bench/scaling.gp)
set terminal pngcairo size 1280,520 font 'sans,10'
set output 'docs/bench/scaling.png'
set multiplot layout 1,2
set logscale xy
set grid
set key top left
set ylabel 'seconds'
set y2label 'peak memory (MB)'
set y2tics
set logscale y2
set xlabel 'input triangles'
set title 'Generated floors: abuffer R50 8x8, no DM, patch, reach 8 m' noenhanced
plot 'docs/bench/scaling.dat' index 0 using 1:2 with linespoints pt 7 title 'bake wall time', 'docs/bench/scaling.dat' index 0 using 1:3 axes x1y2 with linespoints pt 5 title 'peak memory'
set xlabel 'light triangles'
set title 'Light triangles (9,600-triangle floor)'
plot 'docs/bench/scaling.dat' index 1 using 4:2 with linespoints pt 7 title 'bake wall time', 'docs/bench/scaling.dat' index 1 using 4:3 axes x1y2 with linespoints pt 5 title 'peak memory'
unset multiplot
