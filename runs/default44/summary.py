import json,sys
def rows(p):
    d=json.load(open(p)); out=[]
    for m in d['models']:
        for ds in m['datasets']:
            for w in ds['windows']:
                w=dict(w); w['data']=ds['data']; w['events']=ds['events']; w['scale']=m.get('output_threshold_scale',1); out.append(w)
    return out
def wavg(rs, w, key):
    sel=[r for r in rs if abs(r['window_ms']-w)<1e-6]
    n=sum(r['windows'] for r in sel)
    return sum(r[key]*r['windows'] for r in sel)/n if n else float('nan'), n
for name in sys.argv[1:]:
    base=f'out/eval44/{name}'
    out=[name]
    try:
        rs=rows(base+'/rooms/results.json')
        for w in (20,100):
            i,n=wavg(rs,w,'iou_mean'); dr,_=wavg(rs,w,'detection_rate'); out.append(f'{w}ms IoU {i:.1f} det {dr:.1f}')
        sel=[r for r in rs if r['window_ms']==20]; tp=sum(r['event_counts']['tp'] for r in sel); fp=sum(r['event_counts']['fp'] for r in sel); fn=sum(r['event_counts']['fn'] for r in sel)
        out.append(f'P/R {100*tp/(tp+fp):.1f}/{100*tp/(tp+fn):.1f}')
        rs=rows(base+'/authors/results.json')
        for w in (20,100):
            i,n=wavg(rs,w,'iou_mean'); dr,_=wavg(rs,w,'detection_rate'); out.append(f'authors {w}ms {i:.1f} det {dr:.1f} (n={n})')
    except Exception as e: out.append('ERR '+repr(e))
    try: out.append(open(base+'/poster-segment.txt').read().strip())
    except Exception as e: pass
    try:
        rs=rows(base+'/real/results.json'); tot=0; mv=0
        for r in rs:
            if abs(r['window_ms']-20)<1e-6 and r['moving_share'] is not None:
                out.append(f"{r['data'].split('/')[-1]} {r['moving_share']:.2f}"); tot+=r['events']; mv+=r['moving_share']*r['events']
        out.append(f'weighted {mv/tot:.2f}')
    except Exception as e: out.append('real ERR '+repr(e))
    print('\n  '.join(out))
