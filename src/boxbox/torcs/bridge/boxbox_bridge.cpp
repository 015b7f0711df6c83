// boxbox bridge: a TORCS robot module that forwards every robot callback to a Python
// process over a Unix SOCK_SEQPACKET socket and applies the answers.  No driving logic here.
//
// Copyright (C) 2026 the boxbox authors.  GPL-2.0-or-later.
// The message layouts come from the generated bb_wire.h (see boxbox/torcs/wire.py).

#include <cmath>
#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <sys/un.h>
#include <unistd.h>

#include <tgf.h>
#include <track.h>
#include <car.h>
#include <raceman.h>
#include <robot.h>
#include <robottools.h>

#include "bb_wire.h"

#define BB_MAX_ROBOTS 10

static int g_fd = -1;
static bool g_dead = false;          // after a fault: brake every car, ask nothing more
static int g_dead_steps = 0;
static int g_step_budget_ms = 200;   // drive step budget
static int g_setup_budget_ms = 30000;
static int g_current_timeout_ms = -1;
static int g_step[BB_MAX_ROBOTS];
static tCarElt *g_car[BB_MAX_ROBOTS];  // each car and the situation, for rbShutdown (given neither)
static tSituation *g_situation = NULL;
static char g_names[BB_MAX_ROBOTS][32];
static unsigned char g_out[BB_MAX_MESSAGE_BYTES + 64];
static unsigned char g_in[BB_MAX_MESSAGE_BYTES + 64];

// After a fault TORCS keeps simulating; the car brakes for this many steps, then the
// process ends so that a race can never hang on a robot that is gone.
static const int BB_DEAD_STEPS_BEFORE_EXIT = 50;

static void bb_fault(const char *what, int robot, int step) {
    if (!g_dead) {
        fprintf(stderr, "BOXBOX-FAULT %s robot=%d step=%d\n", what, robot, step);
        fflush(stderr);
    }
    g_dead = true;
}

static void bb_set_timeout(int ms) {
    if (ms == g_current_timeout_ms) return;
    struct timeval tv;
    tv.tv_sec = ms / 1000;
    tv.tv_usec = (ms % 1000) * 1000;
    setsockopt(g_fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));
    g_current_timeout_ms = ms;
}

static int env_int(const char *name, int deflt) {
    const char *v = getenv(name);
    return (v && *v) ? atoi(v) : deflt;
}

// Send one message; payload may be NULL.
static bool bb_send(int kind, int robot, int step, int count, const void *payload, size_t n) {
    bb_header h = {kind, robot, step, count};
    memcpy(g_out, &h, sizeof h);
    if (n) memcpy(g_out + sizeof h, payload, n);
    ssize_t sent = send(g_fd, g_out, sizeof h + n, MSG_NOSIGNAL);
    return sent == (ssize_t)(sizeof h + n);
}

// Wait for the answer to (kind, robot, step); returns payload bytes or -1 on fault.
static ssize_t bb_recv(int kind, int robot, int step, int timeout_ms, int *flags) {
    bb_set_timeout(timeout_ms);
    for (;;) {
        ssize_t n = recv(g_fd, g_in, sizeof g_in, 0);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
            // the budget and the awaited answer say which call hung (a drive step, on_track...)
            if (!g_dead) {
                fprintf(stderr, "BOXBOX-FAULT timeout robot=%d step=%d budget_ms=%d answer=%d\n",
                        robot, step, timeout_ms, kind);
                fflush(stderr);
            }
            g_dead = true;
            return -1;
        }
        if (n < (ssize_t)sizeof(bb_header)) {
            bb_fault("host-gone", robot, step);
            return -1;
        }
        bb_header h;
        memcpy(&h, g_in, sizeof h);
        if (h.kind != kind || h.robot != robot || h.step != step) continue;  // stale answer
        *flags = h.count;
        if (h.count & BB_FLAG_FAULT) {
            bb_fault("robot", robot, step);
            return -1;
        }
        return n - (ssize_t)sizeof h;
    }
}

static bool bb_connect(void) {
    if (g_fd >= 0) return true;
    if (g_dead) return false;
    const char *path = getenv("BOXBOX_SOCKET");
    if (!path || !*path) {
        fprintf(stderr, "boxbox bridge: BOXBOX_SOCKET is not set; start races with `boxbox race`\n");
        exit(3);
    }
    g_step_budget_ms = env_int("BOXBOX_STEP_BUDGET_MS", g_step_budget_ms);
    g_setup_budget_ms = env_int("BOXBOX_SETUP_BUDGET_MS", g_setup_budget_ms);
    g_fd = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
    struct sockaddr_un addr;
    memset(&addr, 0, sizeof addr);
    addr.sun_family = AF_UNIX;
    strncpy(addr.sun_path, path, sizeof(addr.sun_path) - 1);
    if (g_fd < 0 || connect(g_fd, (struct sockaddr *)&addr, sizeof addr) != 0) {
        fprintf(stderr, "BOXBOX-FAULT connect robot=-1 step=0 (%s: %s)\n", path, strerror(errno));
        exit(3);
    }
    bb_hello hello = {BB_PROTOCOL_VERSION, (double)sizeof(tCarElt), (double)getpid()};
    int flags = 0;
    if (!bb_send(BB_HELLO, -1, 0, 0, &hello, sizeof hello) || bb_recv(BB_HELLO, -1, 0, g_setup_budget_ms, &flags) < 0) {
        exit(3);
    }
    bb_hello answer;
    memcpy(&answer, g_in + sizeof(bb_header), sizeof answer);
    if ((int)answer.protocol_version != BB_PROTOCOL_VERSION) {
        fprintf(stderr, "BOXBOX-FAULT protocol robot=-1 step=0 (host %d, bridge %d)\n",
                (int)answer.protocol_version, BB_PROTOCOL_VERSION);
        exit(3);
    }
    return true;
}

static double side_width(tTrackSeg *side) { return side ? side->startWidth : 0.0; }
static double side_friction(tTrackSeg *side) { return (side && side->surface) ? side->surface->kFriction : 0.0; }
static double seg_id(tTrackSeg *seg) { return seg ? seg->id : -1.0; }

// One side's parts, outward from the main segment (track4.cpp builds main -> border -> side, each
// optional, and a barrier per side): the doubles of wire.py's SIDE_PART_FIELDS, in that order.
static_assert(BB_SIDE_PART_FIELDS == 12, "fill_side_parts writes 12 fields");
static void fill_side_parts(double *out, tTrackSeg *s, int side) {
    for (int i = 0; i < BB_SIDE_PART_FIELDS; i++) out[i] = 0.0;
    tTrackSeg *part = s->side[side];
    if (part && (part->type2 == TR_LBORDER || part->type2 == TR_RBORDER)) {
        out[0] = part->startWidth; out[1] = part->style; out[2] = part->height;
        out[3] = part->surface ? part->surface->kFriction : 0.0;
        out[4] = part->surface ? part->surface->kRoughness : 0.0;
        part = part->side[side];
    }
    if (part) {
        out[5] = part->startWidth; out[6] = part->endWidth;
        out[7] = part->surface ? part->surface->kFriction : 0.0;
        out[8] = part->surface ? part->surface->kRollRes : 0.0;
        out[9] = part->surface ? part->surface->kRoughness : 0.0;
    }
    tTrackBarrier *barrier = s->barrier[side];
    if (barrier) { out[10] = barrier->style; out[11] = barrier->width; }
}

static void fill_segment(bb_segment *r, tTrackSeg *s) {
    r->id = s->id; r->type = s->type; r->length_m = s->length; r->width_m = s->width;
    r->start_width_m = s->startWidth; r->end_width_m = s->endWidth; r->start_dist_m = s->lgfromstart;
    r->radius_m = s->radius; r->radius_right_m = s->radiusr; r->radius_left_m = s->radiusl; r->arc_rad = s->arc;
    r->center_x = s->center.x; r->center_y = s->center.y;
    r->start_left_x = s->vertex[TR_SL].x; r->start_left_y = s->vertex[TR_SL].y;
    r->start_right_x = s->vertex[TR_SR].x; r->start_right_y = s->vertex[TR_SR].y;
    r->end_left_x = s->vertex[TR_EL].x; r->end_left_y = s->vertex[TR_EL].y;
    r->end_right_x = s->vertex[TR_ER].x; r->end_right_y = s->vertex[TR_ER].y;
    r->start_z_m = 0.5 * (s->vertex[TR_SL].z + s->vertex[TR_SR].z);
    r->end_z_m = 0.5 * (s->vertex[TR_EL].z + s->vertex[TR_ER].z);
    r->start_angle_rad = s->angle[TR_ZS];
    r->friction = s->surface ? s->surface->kFriction : 1.0;
    r->roll_resistance = s->surface ? s->surface->kRollRes : 0.0;
    r->roughness = s->surface ? s->surface->kRoughness : 0.0;
    r->race_info = s->raceInfo;
    r->left_side_width_m = side_width(s->lside); r->right_side_width_m = side_width(s->rside);
    r->left_side_friction = side_friction(s->lside); r->right_side_friction = side_friction(s->rside);
    r->banking_start_rad = s->angle[TR_XS]; r->banking_end_rad = s->angle[TR_XE];
    fill_side_parts(&r->left_border_width_m, s, TR_SIDE_LFT);
    fill_side_parts(&r->right_border_width_m, s, TR_SIDE_RGT);
}

// The engine's torque curve as the car file lists it: "Engine/data points/1".."n", rpm (read in
// rad/s: TORCS converts units) and Tq (N m).
static void fill_torque_curve(bb_handle *r, void *h) {
    char path[256];
    snprintf(path, sizeof path, "%s/%s", SECT_ENGINE, ARR_DATAPTS);
    int n = GfParmGetEltNb(h, path);
    if (n > BB_MAX_TORQUE_POINTS) n = BB_MAX_TORQUE_POINTS;
    double *rpm = &r->torque_rpm_0, *tq = &r->torque_nm_0;
    for (int i = 0; i < n; i++) {
        snprintf(path, sizeof path, "%s/%s/%d", SECT_ENGINE, ARR_DATAPTS, i + 1);
        rpm[i] = GfParmGetNum(h, path, PRM_RPM, NULL, 0.0);
        tq[i] = GfParmGetNum(h, path, PRM_TQ, NULL, 0.0);
    }
    r->torque_points = n;
}

// The suspension as simuv2 reads it (SimSuspConfig, SimAxleConfig, SimWheelConfig), with its defaults.
static void fill_suspension(bb_handle *r, void *h) {
    r->gc_height_m = GfParmGetNum(h, SECT_CAR, PRM_GCHEIGHT, NULL, 0.5);
    r->front_axle_x_m = GfParmGetNum(h, SECT_FRNTAXLE, PRM_XPOS, NULL, 2.0);
    r->rear_axle_x_m = GfParmGetNum(h, SECT_REARAXLE, PRM_XPOS, NULL, -2.0);
    const char *wheels[4] = {SECT_FRNTRGTWHEEL, SECT_FRNTLFTWHEEL, SECT_REARRGTWHEEL, SECT_REARLFTWHEEL};
    const char *susps[4] = {SECT_FRNTRGTSUSP, SECT_FRNTLFTSUSP, SECT_REARRGTSUSP, SECT_REARLFTSUSP};
    double *out = &r->wheel_y_fr_m;  // 10 fields per wheel, in wire.SUSPENSION_FIELDS order
    for (int i = 0; i < 4; i++, out += 10) {
        out[0] = GfParmGetNum(h, wheels[i], PRM_YPOS, NULL, 0.0);
        out[1] = GfParmGetNum(h, susps[i], PRM_SPR, NULL, 175000.0);
        out[2] = GfParmGetNum(h, susps[i], PRM_BELLCRANK, NULL, 1.0);
        out[3] = GfParmGetNum(h, susps[i], PRM_PACKERS, NULL, 0.0);
        out[4] = GfParmGetNum(h, susps[i], PRM_SLOWBUMP, NULL, 0.0);
        out[5] = GfParmGetNum(h, susps[i], PRM_SLOWREBOUND, NULL, 0.0);
        out[6] = GfParmGetNum(h, susps[i], PRM_FASTBUMP, NULL, out[4]);
        out[7] = GfParmGetNum(h, susps[i], PRM_FASTREBOUND, NULL, out[5]);
        out[8] = GfParmGetNum(h, susps[i], PRM_BUMPTHRESHOLD, NULL, 0.5);
        out[9] = GfParmGetNum(h, susps[i], PRM_REBOUNDTHRESHOLD, NULL, 0.5);
    }
}

static void fill_handle(bb_handle *r, void *h) {
    r->mass_kg = GfParmGetNum(h, SECT_CAR, PRM_MASS, NULL, 1000.0);
    r->tank_l = GfParmGetNum(h, SECT_CAR, PRM_TANK, NULL, 100.0);
    r->initial_fuel_l = GfParmGetNum(h, SECT_CAR, PRM_FUEL, NULL, 100.0);
    r->front_wing_area_m2 = GfParmGetNum(h, SECT_FRNTWING, PRM_WINGAREA, NULL, 0.0);
    r->front_wing_angle_rad = GfParmGetNum(h, SECT_FRNTWING, PRM_WINGANGLE, NULL, 0.0);
    r->rear_wing_area_m2 = GfParmGetNum(h, SECT_REARWING, PRM_WINGAREA, NULL, 0.0);
    r->rear_wing_angle_rad = GfParmGetNum(h, SECT_REARWING, PRM_WINGANGLE, NULL, 0.0);
    r->front_clift = GfParmGetNum(h, SECT_AERODYNAMICS, PRM_FCL, NULL, 0.0);
    r->rear_clift = GfParmGetNum(h, SECT_AERODYNAMICS, PRM_RCL, NULL, 0.0);
    r->cx = GfParmGetNum(h, SECT_AERODYNAMICS, PRM_CX, NULL, 0.0);
    r->front_area_m2 = GfParmGetNum(h, SECT_AERODYNAMICS, PRM_FRNTAREA, NULL, 0.0);
    const char *wheels[4] = {SECT_FRNTRGTWHEEL, SECT_FRNTLFTWHEEL, SECT_REARRGTWHEEL, SECT_REARLFTWHEEL};
    double *ride[4] = {&r->ride_height_fr_m, &r->ride_height_fl_m, &r->ride_height_rr_m, &r->ride_height_rl_m};
    double *mu[4] = {&r->mu_fr, &r->mu_fl, &r->mu_rr, &r->mu_rl};
    for (int i = 0; i < 4; i++) {
        *ride[i] = GfParmGetNum(h, wheels[i], PRM_RIDEHEIGHT, NULL, 0.2);
        *mu[i] = GfParmGetNum(h, wheels[i], PRM_MU, NULL, 1.0);
    }
    double *stiffness = &r->tyre_stiffness_fr, *dyn_friction = &r->tyre_dynamic_friction_fr;
    double *elasticity = &r->tyre_elasticity_fr;
    for (int i = 0; i < 4; i++) {  // TORCS's own defaults where the car file is silent (simuv2)
        stiffness[i] = GfParmGetNum(h, wheels[i], PRM_CA, NULL, 30.0);
        dyn_friction[i] = GfParmGetNum(h, wheels[i], PRM_RFACTOR, NULL, 0.8);
        elasticity[i] = GfParmGetNum(h, wheels[i], PRM_EFACTOR, NULL, 0.7);
    }
    double *lf_max = &r->tyre_load_factor_max_fr, *lf_min = &r->tyre_load_factor_min_fr;
    double *op_load = &r->tyre_operating_load_fr_n;
    for (int i = 0; i < 4; i++) {  // simuv2 keeps max >= 1.6 and min <= 0.8 whatever the file says
        lf_max[i] = GfParmGetNum(h, wheels[i], PRM_LOADFMAX, NULL, 1.6);
        if (lf_max[i] < 1.6) lf_max[i] = 1.6;
        lf_min[i] = GfParmGetNum(h, wheels[i], PRM_LOADFMIN, NULL, 0.8);
        if (lf_min[i] > 0.8) lf_min[i] = 0.8;
        op_load[i] = GfParmGetNum(h, wheels[i], PRM_OPLOAD, NULL, 0.0);
    }
    fill_torque_curve(r, h);
    fill_suspension(r, h);
    const char *train = GfParmGetStr(h, SECT_DRIVETRAIN, PRM_TYPE, VAL_TRANS_RWD);
    r->drivetrain = strcmp(train, VAL_TRANS_FWD) == 0 ? 1 : (strcmp(train, VAL_TRANS_4WD) == 0 ? 2 : 0);
    r->fuel_cons_factor = GfParmGetNum(h, SECT_ENGINE, PRM_FUELCONS, NULL, 1.0);
    r->engine_tickover_radps = GfParmGetNum(h, SECT_ENGINE, PRM_TICKOVER, NULL, 150.0);  // simuv2's defaults
    r->engine_revs_max_radps = GfParmGetNum(h, SECT_ENGINE, PRM_REVSMAX, NULL, 1000.0);
    r->engine_brake_coeff = GfParmGetNum(h, SECT_ENGINE, PRM_ENGBRKCOEFF, NULL, 0.33);
    r->brake_pressure_max = GfParmGetNum(h, SECT_BRKSYST, PRM_BRKPRESS, NULL, 0.0);
    r->brake_front_rear = GfParmGetNum(h, SECT_BRKSYST, PRM_BRKREP, NULL, 0.5);
    const char *brakes[4] = {SECT_FRNTRGTBRAKE, SECT_FRNTLFTBRAKE, SECT_REARRGTBRAKE, SECT_REARLFTBRAKE};
    double *disk = &r->brake_disk_diameter_fr_m, *piston = &r->brake_piston_area_fr_m2, *pad = &r->brake_mu_fr;
    for (int i = 0; i < 4; i++) {  // simuv2's defaults (brake.cpp): its torque is disk / 2 x area x mu x pressure
        disk[i] = GfParmGetNum(h, brakes[i], PRM_BRKDIAM, NULL, 0.2);
        piston[i] = GfParmGetNum(h, brakes[i], PRM_BRKAREA, NULL, 0.002);
        pad[i] = GfParmGetNum(h, brakes[i], PRM_MU, NULL, 0.30);
    }
    r->front_weight_share = GfParmGetNum(h, SECT_CAR, PRM_FRWEIGHTREP, NULL, 0.5);
}

static void newTrack(int index, tTrack *track, void *carHandle, void **carParmHandle, tSituation *s) {
    *carParmHandle = NULL;
    if (!bb_connect()) return;
    // One blob: TRACK, n x SEGMENT, HANDLE; sent in chunks under the message limit.
    size_t nseg = track->nseg;
    size_t size = sizeof(bb_track) + nseg * sizeof(bb_segment) + sizeof(bb_handle);
    unsigned char *blob = (unsigned char *)calloc(1, size);
    bb_track *t = (bb_track *)blob;
    tTrackPitInfo *p = &track->pits;
    t->length_m = track->length; t->width_m = track->width; t->n_segments = nseg;
    t->pit_type = p->type; t->pit_side = p->side;
    t->pit_entry_seg = seg_id(p->pitEntry); t->pit_start_seg = seg_id(p->pitStart);
    t->pit_end_seg = seg_id(p->pitEnd); t->pit_exit_seg = seg_id(p->pitExit);
    t->pit_width_m = p->width; t->pit_box_length_m = p->len; t->pit_speed_limit_mps = p->speedLimit;
    t->pit_count = p->nMaxPits;
    bb_segment *segs = (bb_segment *)(blob + sizeof(bb_track));
    tTrackSeg *seg = track->seg->next;  // track->seg is the last segment
    for (size_t i = 0; i < nseg; i++, seg = seg->next) fill_segment(&segs[i], seg);
    fill_handle((bb_handle *)(blob + sizeof(bb_track) + nseg * sizeof(bb_segment)), carHandle);

    const size_t chunk = BB_MAX_MESSAGE_BYTES;
    int nchunks = (int)((size + chunk - 1) / chunk);
    bool ok = true;
    for (int c = 0; c < nchunks && ok; c++) {
        size_t off = c * chunk, n = size - off < chunk ? size - off : chunk;
        ok = bb_send(BB_NEW_TRACK, index, c, nchunks, blob + off, n);
    }
    free(blob);
    int flags = 0;
    if (!ok) { bb_fault("host-gone", index, 0); return; }
    if (bb_recv(BB_FUEL, index, nchunks - 1, g_setup_budget_ms, &flags) < 0) return;
    bb_fuel fuel;
    memcpy(&fuel, g_in + sizeof(bb_header), sizeof fuel);
    const double *setup = &fuel.setup_0;  // a value per place of the car's file (BB_SETUP_PLACES), NaN: its own
    bool any = fuel.initial_fuel_l >= 0;
    for (int i = 0; i < BB_SETUP_SLOTS; i++) any = any || !std::isnan(setup[i]);
    if (any) {
        // the robot's setup, merged by TORCS over the car's file (within its min and max)
        char path[1024];
        snprintf(path, sizeof path, "%sdrivers/boxbox/setup-%d.xml", GetLocalDir(), index);
        void *h = GfParmReadFile(path, GFPARM_RMODE_STD | GFPARM_RMODE_CREAT);
        if (fuel.initial_fuel_l >= 0) GfParmSetNum(h, SECT_CAR, PRM_FUEL, NULL, (tdble)fuel.initial_fuel_l);
        for (int i = 0; i < BB_SETUP_SLOTS; i++)
            if (!std::isnan(setup[i])) GfParmSetNum(h, BB_SETUP_PLACES[i][0], BB_SETUP_PLACES[i][1], NULL, (tdble)setup[i]);
        *carParmHandle = h;
    }
}

static void newRace(int index, tCarElt *car, tSituation *s) {
    g_step[index] = 0;
    g_car[index] = car;
    g_situation = s;
    if (g_dead || !bb_connect()) return;
    bb_car r;
    memset(&r, 0, sizeof r);
    r.car_index = car->index; r.gear_count = car->_gearNb; r.gear_offset = car->_gearOffset;
    double *ratios = &r.gear_ratio_0;
    for (int i = 0; i < MAX_GEARS; i++) ratios[i] = car->_gearRatio[i];
    r.rpm_redline = car->_enginerpmRedLine; r.rpm_max = car->_enginerpmMax;
    r.rpm_max_torque = car->_enginerpmMaxTq; r.rpm_max_power = car->_enginerpmMaxPw;
    r.max_torque_nm = car->_engineMaxTq; r.max_power_w = car->_engineMaxPw;
    r.wheel_radius_fr_m = car->_wheelRadius(FRNT_RGT); r.wheel_radius_fl_m = car->_wheelRadius(FRNT_LFT);
    r.wheel_radius_rr_m = car->_wheelRadius(REAR_RGT); r.wheel_radius_rl_m = car->_wheelRadius(REAR_LFT);
    r.steer_lock_rad = car->_steerLock;
    r.length_m = car->_dimension_x; r.width_m = car->_dimension_y; r.height_m = car->_dimension_z;
    r.tank_l = car->_tank;
    if (car->_pit) {
        r.pit_seg = car->_pit->pos.seg ? car->_pit->pos.seg->id : -1;
        r.pit_to_start = car->_pit->pos.toStart; r.pit_to_middle_m = car->_pit->pos.toMiddle;
        r.pit_lmin_m = car->_pit->lmin; r.pit_lmax_m = car->_pit->lmax;
    } else {
        r.pit_seg = -1;
    }
    r.start_rank = car->_startRank; r.race_laps = s->_totLaps;
    r.skill_level = car->_skillLevel;
    int flags = 0;
    if (!bb_send(BB_NEW_RACE, index, 0, 0, &r, sizeof r)) { bb_fault("host-gone", index, 0); return; }
    bb_recv(BB_ACK, index, 0, g_setup_budget_ms, &flags);
}

static void fill_state(bb_state *r, tCarElt *car, tSituation *s) {
    r->sim_time_s = s->currentTime;
    r->x_m = car->_pos_X; r->y_m = car->_pos_Y; r->z_m = car->_pos_Z;
    r->yaw_rad = car->_yaw; r->roll_rad = car->_roll; r->pitch_rad = car->_pitch;
    r->speed_x_mps = car->_speed_x; r->speed_y_mps = car->_speed_y; r->speed_z_mps = car->_speed_z;
    r->yaw_rate_rps = car->_yaw_rate; r->accel_x_mps2 = car->_accel_x; r->accel_y_mps2 = car->_accel_y;
    tTrkLocPos *p = &car->_trkPos;
    r->seg_id = p->seg ? p->seg->id : -1;
    r->to_start = p->toStart; r->to_right_m = p->toRight; r->to_middle_m = p->toMiddle; r->to_left_m = p->toLeft;
    double angle = p->seg ? RtTrackSideTgAngleL(p) - car->_yaw : 0.0;
    NORM_PI_PI(angle);
    r->angle_rad = angle;
    r->dist_from_start_m = car->_distFromStartLine; r->dist_raced_m = car->_distRaced;
    r->gear = car->_gear; r->rpm = car->_enginerpm;
    r->spin_fr_rps = car->_wheelSpinVel(FRNT_RGT); r->spin_fl_rps = car->_wheelSpinVel(FRNT_LFT);
    r->spin_rr_rps = car->_wheelSpinVel(REAR_RGT); r->spin_rl_rps = car->_wheelSpinVel(REAR_LFT);
    r->fuel_l = car->_fuel; r->damage = car->_dammage;
    r->laps = car->_laps; r->remaining_laps = car->_remainingLaps; r->total_laps = s->_totLaps;
    r->position = car->_pos;
    r->cur_lap_time_s = car->_curLapTime; r->last_lap_time_s = car->_lastLapTime;
    r->best_lap_time_s = car->_bestLapTime; r->race_time_s = car->_curTime;
    r->car_state = car->_state; r->pit_stops = car->_nbPitStops; r->penalty_time_s = car->_penaltyTime;
    r->top_speed_mps = car->_topSpeed;
    r->n_opponents = s->_ncars - 1;
    // simuv2 keeps the wheel's centre at its radius minus the travel below the CG's plane
    // (wheel.cpp: relPos.z = radius - x): the travel, ride height at rest, 0 on the packers
    double *travel = &r->travel_fr_m;
    const int wheels[4] = {FRNT_RGT, FRNT_LFT, REAR_RGT, REAR_LFT};
    for (int i = 0; i < 4; i++) travel[i] = car->_wheelRadius(wheels[i]) - car->_ride(wheels[i]);
}

static void fill_opponent(bb_opponent *r, tCarElt *o) {
    r->car_index = o->index; r->x_m = o->_pos_X; r->y_m = o->_pos_Y; r->yaw_rad = o->_yaw;
    r->speed_x_mps = o->_speed_x; r->speed_y_mps = o->_speed_y;
    r->speed_mps = sqrt(o->_speed_X * o->_speed_X + o->_speed_Y * o->_speed_Y);
    r->seg_id = o->_trkPos.seg ? o->_trkPos.seg->id : -1;
    r->to_start = o->_trkPos.toStart; r->to_middle_m = o->_trkPos.toMiddle;
    r->dist_from_start_m = o->_distFromStartLine; r->dist_raced_m = o->_distRaced;
    r->laps = o->_laps; r->last_lap_time_s = o->_lastLapTime; r->best_lap_time_s = o->_bestLapTime;
    r->car_state = o->_state; r->damage = o->_dammage;
    r->length_m = o->_dimension_x; r->width_m = o->_dimension_y;
}

static void brake_safely(tCarElt *car) {
    car->_steerCmd = 0.0f; car->_accelCmd = 0.0f; car->_brakeCmd = 1.0f; car->_clutchCmd = 0.0f;
    car->_gearCmd = car->_gear > 0 ? car->_gear : 1;
    car->_raceCmd = RM_CMD_NONE;
    if (++g_dead_steps > BB_DEAD_STEPS_BEFORE_EXIT) {
        fprintf(stderr, "BOXBOX-ABORT the race is stopped after a robot fault\n");
        fflush(stderr);
        _exit(4);
    }
}

static float clampf(double v, double lo, double hi) {
    if (!(v == v)) return (float)lo;
    return (float)(v < lo ? lo : (v > hi ? hi : v));
}

static bool send_drive(int index, tCarElt *car, tSituation *s, int step) {
    static unsigned char buf[sizeof(bb_state) + BB_MAX_OPPONENTS * sizeof(bb_opponent)];
    bb_state *st = (bb_state *)buf;
    fill_state(st, car, s);
    bb_opponent *opp = (bb_opponent *)(buf + sizeof(bb_state));
    int n = 0;
    for (int i = 0; i < s->_ncars && n < BB_MAX_OPPONENTS; i++) {
        if (s->cars[i] != car) fill_opponent(&opp[n++], s->cars[i]);
    }
    st->n_opponents = n;
    if (!bb_send(BB_DRIVE, index, step, n, buf, sizeof(bb_state) + n * sizeof(bb_opponent))) {
        bb_fault("host-gone", index, step);
        return false;
    }
    return true;
}

// BOXBOX_BATCH_DRIVE=1 (the Gymnasium env with several learning cars): at the first Python car's
// drive call of a simulation step, every Python car TORCS will drive in it is sent its DRIVE, then
// the answers are read in the same order, so the host sees all the cars' states of one step before
// it answers any (TORCS moves the cars only after every robot's drive call).
static int g_batch = -1;  // -1: not read yet
static double g_batch_time = -1e300;
static bool g_batch_ok[BB_MAX_ROBOTS];
static bb_controls g_batch_controls[BB_MAX_ROBOTS];

static void drive_batch(tSituation *s) {
    g_batch_time = s->currentTime;
    int sent[BB_MAX_ROBOTS], nsent = 0;
    for (int j = 0; j < BB_MAX_ROBOTS; j++) {
        g_batch_ok[j] = false;
        tCarElt *c = g_car[j];
        if (!c || (c->_state & RM_CAR_STATE_NO_SIMU) || g_dead) continue;
        if (send_drive(j, c, s, ++g_step[j])) sent[nsent++] = j;
    }
    for (int k = 0; k < nsent && !g_dead; k++) {
        int j = sent[k], flags = 0;
        if (bb_recv(BB_CONTROLS, j, g_step[j], g_step_budget_ms, &flags) < 0) break;
        memcpy(&g_batch_controls[j], g_in + sizeof(bb_header), sizeof(bb_controls));
        g_batch_ok[j] = true;
    }
}

static void drive(int index, tCarElt *car, tSituation *s) {
    if (g_batch < 0) g_batch = env_int("BOXBOX_BATCH_DRIVE", 0) ? 1 : 0;
    bb_controls c;
    if (g_batch) {
        if (!g_dead && s->currentTime != g_batch_time) drive_batch(s);
        if (g_dead || !g_batch_ok[index]) { brake_safely(car); return; }
        c = g_batch_controls[index];
    } else {
        int step = ++g_step[index];
        if (g_dead) { brake_safely(car); return; }
        if (!send_drive(index, car, s, step)) { brake_safely(car); return; }
        int flags = 0;
        if (bb_recv(BB_CONTROLS, index, step, g_step_budget_ms, &flags) < 0) { brake_safely(car); return; }
        memcpy(&c, g_in + sizeof(bb_header), sizeof c);
    }
    car->_steerCmd = clampf(c.steer, -1.0, 1.0);
    car->_accelCmd = clampf(c.accel, 0.0, 1.0);
    car->_brakeCmd = clampf(c.brake, 0.0, 1.0);
    car->_clutchCmd = clampf(c.clutch, 0.0, 1.0);
    car->_gearCmd = (int)c.gear;
    car->_raceCmd = c.pit_request > 0.5 ? RM_CMD_PIT_ASKED : RM_CMD_NONE;
}

static int pitCmd(int index, tCarElt *car, tSituation *s) {
    car->_pitFuel = 0.0f;
    car->_pitRepair = 0;
    if (g_dead) return ROB_PIT_IM;
    bb_state st;
    fill_state(&st, car, s);
    int flags = 0, step = g_step[index];
    if (!bb_send(BB_PIT_CMD, index, step, 0, &st, sizeof st)) { bb_fault("host-gone", index, step); return ROB_PIT_IM; }
    if (bb_recv(BB_PIT_ORDER, index, step, g_setup_budget_ms, &flags) < 0) return ROB_PIT_IM;
    bb_pit_order o;
    memcpy(&o, g_in + sizeof(bb_header), sizeof o);
    car->_pitFuel = clampf(o.fuel_l, 0.0, 1e6);
    car->_pitRepair = (int)clampf(o.repair, 0.0, 1e7);
    return ROB_PIT_IM;
}

static void endRace(int index, tCarElt *car, tSituation *s) {
    if (g_dead || g_fd < 0) return;
    bb_state st;
    fill_state(&st, car, s);
    int flags = 0, step = g_step[index];
    if (bb_send(BB_END_RACE, index, step, 0, &st, sizeof st)) bb_recv(BB_ACK, index, step, g_setup_budget_ms, &flags);
}

// TORCS 1.3 never calls rbEndRace: the end of a race reaches a robot only as rbShutdown, when the
// race is cleaned up (the cars and the track are still there).  The car's state then goes with it,
// so the host can call on_race_end with the finish (the last drive step was often before it).
static void rbShutdownCb(int index) {
    if (g_fd < 0 || g_dead) return;
    if (index >= 0 && index < BB_MAX_ROBOTS && g_car[index] && g_situation) {
        bb_state st;
        fill_state(&st, g_car[index], g_situation);
        st.n_opponents = 0;
        bb_send(BB_SHUTDOWN, index, g_step[index], 0, &st, sizeof st);
    } else {
        bb_send(BB_SHUTDOWN, index, g_step[index], 0, NULL, 0);
    }
}

static int initFuncPt(int index, void *pt) {
    tRobotItf *itf = (tRobotItf *)pt;
    itf->rbNewTrack = newTrack;
    itf->rbNewRace = newRace;
    itf->rbDrive = drive;
    itf->rbPitCmd = pitCmd;
    itf->rbEndRace = endRace;
    itf->rbShutdown = rbShutdownCb;
    itf->index = index;
    return 0;
}

extern "C" int boxbox(tModInfo *modInfo) {
    memset(modInfo, 0, BB_MAX_ROBOTS * sizeof(tModInfo));
    for (int i = 0; i < BB_MAX_ROBOTS; i++) {
        // TORCS frees name and desc when it unloads the module: they must be heap copies.
        snprintf(g_names[i], sizeof g_names[i], "boxbox %d", i + 1);
        modInfo[i].name = strdup(g_names[i]);
        modInfo[i].desc = strdup("Python robot driven through the boxbox bridge");
        modInfo[i].fctInit = initFuncPt;
        modInfo[i].gfId = ROB_IDENT;
        modInfo[i].index = i;
    }
    return 0;
}
