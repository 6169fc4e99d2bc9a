import json,re,sys
txt=open(sys.argv[1]).read()
for block in re.split(r'^## ', txt, flags=re.M)[1:]:
    head=block.split('\n')[0]
    peers_line=[l for l in block.split('\n') if l.startswith('peers:')][0]
    peers=[json.loads(x) for x in re.findall(r'\{[^{}]*\}', peers_line)]
    j=block[block.index('\n{')+1:]
    try: d=json.JSONDecoder().raw_decode(j)[0]  # stderr lines may follow the object
    except Exception as e: print(head,'incomplete',e); continue
    print('##',head, 'dims',d['dims'], 'load', d['loadavg'])
    for m in d['methods']:
        print('  volga %-10s a=%-4s %.3fs tris %8d H %.3f to_rms %.3f sharp %.3f n %.2f man %s'%(m['method'],m['adaptivity'],m['seconds'],m['triangles'],m['hausdorff'],m['to_mesh_rms'],m['sharp_edge_max'],m['normal_rms_degrees'],m['manifold']))
    for p,s in zip(peers,d['scored']):
        print('  %-16s %.3fs tris %8d H %.3f to_rms %.3f sharp %.3f n %.2f man %s (%d/%d)'%(p['peer'],p['median_s'],s['triangles'],s['hausdorff'],s['to_mesh_rms'],s['sharp_edge_max'],s['normal_rms_degrees'],s['manifold'],s['edges_not_in_two_faces'],s['inconsistent_edges']))
    print('  slider build %.3f'%d['iso_slider']['build_s'], [(round(v['iso'],1),v['candidate_blocks'],round(v['index_s'],3),round(v['fresh_s'],3),v['identical']) for v in d['iso_slider']['values']])
