% Intrinsic and Extrinsic Camera Parameters
%

%-- Focal length:
fc = [ 500.25 ; 501.5 ];

%-- Principal point:
cc = [ 319.5 ; 239.5 ];

%-- Skew coefficient:
alpha_c = 0.000000000000000;

%-- Distortion coefficients:
kc = [ -0.1 ; 0.02 ; 0.001 ; -0.0005 ; 0.000000000000000 ];

%-- Focal length uncertainty:
fc_error = [ 0.5 ; 0.5 ];

%-- Principal point uncertainty:
cc_error = [ 1.0 ; 1.0 ];

%-- Skew coefficient uncertainty:
alpha_c_error = 0.000000000000000;

%-- Distortion coefficients uncertainty:
kc_error = [ 0.01 ; 0.02 ; 0.0001 ; 0.0001 ; 0 ];

%-- Image size:
nx = 640;
ny = 480;

n_ima = 2;			% Number of calibration images
est_fc = [ 1 ; 1 ];
est_aspect_ratio = 1;
center_optim = 1;
est_alpha = 0;
est_dist = [ 1 ; 1 ; 1 ; 1 ; 0 ];

%-- Image #1:
omc_1 = [ 1.5e+000 ; 1.6e+000 ; -6.7e-001 ];
Tc_1  = [ -1.7e+02 ; -8.3e+01 ; 8.5e+02 ];
omc_error_1 = [ 7.5e-04 ; 9.7e-04 ; 1.2e-03 ];
Tc_error_1  = [ 8.3e-001 ; 7.7e-001 ; 4.2e-001 ];

%-- Image #2:
omc_2 = [ NaN ; NaN ; NaN ];
Tc_2  = [ NaN ; NaN ; NaN ];
