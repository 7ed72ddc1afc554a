// spheres10.pov -- written by bench/mkspheres.py: the same scene as
// bench/scenes/spheres10.json for POV-Ray 3.7 (see that script for the mapping).
// povray +Ispheres10.pov +W1920 +H1080 -A +WT1 -D
#version 3.7;
global_settings { assumed_gamma 1.0 max_trace_level 6 ambient_light rgb 1 }
background { rgb <0.35, 0.55, 0.85> }
camera { perspective location <0, 5.5, 9> look_at <0, 0, -0.8> sky <0, 1, 0>
         right -x*image_width/image_height up y angle 60 }
light_source { <-6, 10, 8> color rgb <0.7, 0.7, 0.7> }
light_source { <8, 12, -3> color rgb <0.5, 0.475, 0.425> }
#declare M_floor = texture { pigment { rgb <0.75, 0.75, 0.7> } finish { ambient 0.1 diffuse 0.8 } }
#declare M_mirror = texture { pigment { rgb <0.9, 0.9, 0.9> } finish { ambient 0.05 diffuse 0.1 specular 0.8 roughness 0.005 reflection { 0.8 } } }
#declare M_red = texture { pigment { rgb <0.9, 0.15, 0.1> } finish { ambient 0.1 diffuse 0.8 specular 0.4 roughness 0.025 } }
#declare M_green = texture { pigment { rgb <0.15, 0.8, 0.2> } finish { ambient 0.1 diffuse 0.8 specular 0.4 roughness 0.025 } }
#declare M_blue = texture { pigment { rgb <0.15, 0.3, 0.9> } finish { ambient 0.1 diffuse 0.8 specular 0.4 roughness 0.025 } }
plane { y, 0 texture { M_floor } }
sphere { <-4.5, 0.4, -6.5>, 0.4 texture { M_mirror } }
sphere { <-3.5, 0.4, -6.5>, 0.4 texture { M_red } }
sphere { <-2.5, 0.4, -6.5>, 0.4 texture { M_red } }
sphere { <-1.5, 0.4, -6.5>, 0.4 texture { M_mirror } }
sphere { <-0.5, 0.4, -6.5>, 0.4 texture { M_green } }
sphere { <0.5, 0.4, -6.5>, 0.4 texture { M_green } }
sphere { <1.5, 0.4, -6.5>, 0.4 texture { M_mirror } }
sphere { <2.5, 0.4, -6.5>, 0.4 texture { M_blue } }
sphere { <3.5, 0.4, -6.5>, 0.4 texture { M_blue } }
sphere { <4.5, 0.4, -6.5>, 0.4 texture { M_mirror } }
sphere { <-4.5, 0.4, -5.5>, 0.4 texture { M_green } }
sphere { <-3.5, 0.4, -5.5>, 0.4 texture { M_green } }
sphere { <-2.5, 0.4, -5.5>, 0.4 texture { M_mirror } }
sphere { <-1.5, 0.4, -5.5>, 0.4 texture { M_blue } }
sphere { <-0.5, 0.4, -5.5>, 0.4 texture { M_blue } }
sphere { <0.5, 0.4, -5.5>, 0.4 texture { M_mirror } }
sphere { <1.5, 0.4, -5.5>, 0.4 texture { M_red } }
sphere { <2.5, 0.4, -5.5>, 0.4 texture { M_red } }
sphere { <3.5, 0.4, -5.5>, 0.4 texture { M_mirror } }
sphere { <4.5, 0.4, -5.5>, 0.4 texture { M_green } }
sphere { <-4.5, 0.4, -4.5>, 0.4 texture { M_blue } }
sphere { <-3.5, 0.4, -4.5>, 0.4 texture { M_mirror } }
sphere { <-2.5, 0.4, -4.5>, 0.4 texture { M_red } }
sphere { <-1.5, 0.4, -4.5>, 0.4 texture { M_red } }
sphere { <-0.5, 0.4, -4.5>, 0.4 texture { M_mirror } }
sphere { <0.5, 0.4, -4.5>, 0.4 texture { M_green } }
sphere { <1.5, 0.4, -4.5>, 0.4 texture { M_green } }
sphere { <2.5, 0.4, -4.5>, 0.4 texture { M_mirror } }
sphere { <3.5, 0.4, -4.5>, 0.4 texture { M_blue } }
sphere { <4.5, 0.4, -4.5>, 0.4 texture { M_blue } }
sphere { <-4.5, 0.4, -3.5>, 0.4 texture { M_mirror } }
sphere { <-3.5, 0.4, -3.5>, 0.4 texture { M_green } }
sphere { <-2.5, 0.4, -3.5>, 0.4 texture { M_green } }
sphere { <-1.5, 0.4, -3.5>, 0.4 texture { M_mirror } }
sphere { <-0.5, 0.4, -3.5>, 0.4 texture { M_blue } }
sphere { <0.5, 0.4, -3.5>, 0.4 texture { M_blue } }
sphere { <1.5, 0.4, -3.5>, 0.4 texture { M_mirror } }
sphere { <2.5, 0.4, -3.5>, 0.4 texture { M_red } }
sphere { <3.5, 0.4, -3.5>, 0.4 texture { M_red } }
sphere { <4.5, 0.4, -3.5>, 0.4 texture { M_mirror } }
sphere { <-4.5, 0.4, -2.5>, 0.4 texture { M_blue } }
sphere { <-3.5, 0.4, -2.5>, 0.4 texture { M_blue } }
sphere { <-2.5, 0.4, -2.5>, 0.4 texture { M_mirror } }
sphere { <-1.5, 0.4, -2.5>, 0.4 texture { M_red } }
sphere { <-0.5, 0.4, -2.5>, 0.4 texture { M_red } }
sphere { <0.5, 0.4, -2.5>, 0.4 texture { M_mirror } }
sphere { <1.5, 0.4, -2.5>, 0.4 texture { M_green } }
sphere { <2.5, 0.4, -2.5>, 0.4 texture { M_green } }
sphere { <3.5, 0.4, -2.5>, 0.4 texture { M_mirror } }
sphere { <4.5, 0.4, -2.5>, 0.4 texture { M_blue } }
sphere { <-4.5, 0.4, -1.5>, 0.4 texture { M_red } }
sphere { <-3.5, 0.4, -1.5>, 0.4 texture { M_mirror } }
sphere { <-2.5, 0.4, -1.5>, 0.4 texture { M_green } }
sphere { <-1.5, 0.4, -1.5>, 0.4 texture { M_green } }
sphere { <-0.5, 0.4, -1.5>, 0.4 texture { M_mirror } }
sphere { <0.5, 0.4, -1.5>, 0.4 texture { M_blue } }
sphere { <1.5, 0.4, -1.5>, 0.4 texture { M_blue } }
sphere { <2.5, 0.4, -1.5>, 0.4 texture { M_mirror } }
sphere { <3.5, 0.4, -1.5>, 0.4 texture { M_red } }
sphere { <4.5, 0.4, -1.5>, 0.4 texture { M_red } }
sphere { <-4.5, 0.4, -0.5>, 0.4 texture { M_mirror } }
sphere { <-3.5, 0.4, -0.5>, 0.4 texture { M_blue } }
sphere { <-2.5, 0.4, -0.5>, 0.4 texture { M_blue } }
sphere { <-1.5, 0.4, -0.5>, 0.4 texture { M_mirror } }
sphere { <-0.5, 0.4, -0.5>, 0.4 texture { M_red } }
sphere { <0.5, 0.4, -0.5>, 0.4 texture { M_red } }
sphere { <1.5, 0.4, -0.5>, 0.4 texture { M_mirror } }
sphere { <2.5, 0.4, -0.5>, 0.4 texture { M_green } }
sphere { <3.5, 0.4, -0.5>, 0.4 texture { M_green } }
sphere { <4.5, 0.4, -0.5>, 0.4 texture { M_mirror } }
sphere { <-4.5, 0.4, 0.5>, 0.4 texture { M_red } }
sphere { <-3.5, 0.4, 0.5>, 0.4 texture { M_red } }
sphere { <-2.5, 0.4, 0.5>, 0.4 texture { M_mirror } }
sphere { <-1.5, 0.4, 0.5>, 0.4 texture { M_green } }
sphere { <-0.5, 0.4, 0.5>, 0.4 texture { M_green } }
sphere { <0.5, 0.4, 0.5>, 0.4 texture { M_mirror } }
sphere { <1.5, 0.4, 0.5>, 0.4 texture { M_blue } }
sphere { <2.5, 0.4, 0.5>, 0.4 texture { M_blue } }
sphere { <3.5, 0.4, 0.5>, 0.4 texture { M_mirror } }
sphere { <4.5, 0.4, 0.5>, 0.4 texture { M_red } }
sphere { <-4.5, 0.4, 1.5>, 0.4 texture { M_green } }
sphere { <-3.5, 0.4, 1.5>, 0.4 texture { M_mirror } }
sphere { <-2.5, 0.4, 1.5>, 0.4 texture { M_blue } }
sphere { <-1.5, 0.4, 1.5>, 0.4 texture { M_blue } }
sphere { <-0.5, 0.4, 1.5>, 0.4 texture { M_mirror } }
sphere { <0.5, 0.4, 1.5>, 0.4 texture { M_red } }
sphere { <1.5, 0.4, 1.5>, 0.4 texture { M_red } }
sphere { <2.5, 0.4, 1.5>, 0.4 texture { M_mirror } }
sphere { <3.5, 0.4, 1.5>, 0.4 texture { M_green } }
sphere { <4.5, 0.4, 1.5>, 0.4 texture { M_green } }
sphere { <-4.5, 0.4, 2.5>, 0.4 texture { M_mirror } }
sphere { <-3.5, 0.4, 2.5>, 0.4 texture { M_red } }
sphere { <-2.5, 0.4, 2.5>, 0.4 texture { M_red } }
sphere { <-1.5, 0.4, 2.5>, 0.4 texture { M_mirror } }
sphere { <-0.5, 0.4, 2.5>, 0.4 texture { M_green } }
sphere { <0.5, 0.4, 2.5>, 0.4 texture { M_green } }
sphere { <1.5, 0.4, 2.5>, 0.4 texture { M_mirror } }
sphere { <2.5, 0.4, 2.5>, 0.4 texture { M_blue } }
sphere { <3.5, 0.4, 2.5>, 0.4 texture { M_blue } }
sphere { <4.5, 0.4, 2.5>, 0.4 texture { M_mirror } }
